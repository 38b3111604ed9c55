// One entry for a render on either backend: the CPU renderer (render/renderer.h) or the
// Vulkan one (gpu_renderer.h, on the scene baked for it). The command lines and the
// Python binding call this; the options come from resolve_render_options
// (render/options.h).
#pragma once

#include "render/options.h"
#include "render/renderer.h"
#include "render/scene.h"

namespace sss {

// Renders `scene` with `options` on options.backend. Backend::Vulkan bakes the scene for
// the options' integrator, NEE, threshold and models first; in a build without Vulkan it
// throws sss::Error saying so.
RenderResult render_with_backend(const Scene& scene, const RenderOptions& options,
                                 const ProgressFn& progress = {});

}  // namespace sss

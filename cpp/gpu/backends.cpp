#include "gpu/backends.h"

#include "core/check.h"

#ifdef SSSPHERE_HAVE_VULKAN
#include "gpu/gpu_renderer.h"
#include "gpu/gpu_scene_bake.h"
#endif

namespace sss {

RenderResult render_with_backend(const Scene& scene, const RenderOptions& options,
                                 const ProgressFn& progress) {
    if (options.backend == Backend::Cpu) return render(scene, options, progress);
#ifdef SSSPHERE_HAVE_VULKAN
    const bool st = options.integrator == "st";
    GpuSceneData baked =
        bake_gpu_scene(scene, options.integrator, options.nee, options.sphere_threshold,
                       st ? options.models : "", st ? options.cut_models : "");
    VulkanCompute vk;
    GpuRenderer renderer(vk, baked);
    RenderResult r = renderer.render(options, progress);
    r.warnings = baked.warnings;
    return r;
#else
    fail(
        "backend 'vulkan': this build of sssphere has no GPU path (built without Vulkan: "
        "install libvulkan-dev and glslc, then reinstall)");
#endif
}

}  // namespace sss

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
                       st ? options.models : "");
    VulkanCompute vk;
    GpuRenderer renderer(vk, baked);
    GpuRenderResult g = renderer.render(options, progress);
    RenderResult r;
    r.width = g.width;
    r.height = g.height;
    r.image = std::move(g.image);
    r.variance = std::move(g.variance);
    r.events = std::move(g.events);
    r.sphere_steps = std::move(g.sphere_steps);
    r.samples = std::move(g.samples);
    r.path_events = std::move(g.path_events);
    r.path_steps = std::move(g.path_steps);
    r.seconds = g.seconds;
    r.cancelled = g.cancelled;
    r.time_limit_reached = g.time_limit_reached;
    r.spp = g.spp;
    r.total_events = g.total_events;
    r.total_sphere_steps = g.total_sphere_steps;
    r.total_paths = g.total_paths;
    r.gpu_seconds = g.gpu_seconds;
    r.device = g.device;
    return r;
#else
    fail(
        "backend 'vulkan': this build of sssphere has no GPU path (built without Vulkan: "
        "install libvulkan-dev and glslc, then reinstall)");
#endif
}

}  // namespace sss

// Integrators "pt" and "st" on a Vulkan device (cpp/gpu/shaders/render.glsl): one GPU
// invocation per path (or per `lanes`-th path), paths of up to `batch` samples of every
// pixel per dispatch, the per-path results summed on the host into the CPU renderer's
// film (render/film.h). Lights are sampled as the baked scene says
// (gpu_scene_bake.h). Depends on Vulkan and the baked scene only, not on
// Embree or CGAL.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "gpu/gpu_scene.h"
#include "gpu/vulkan_compute.h"
#include "render/film.h"
#include "render/options.h"

namespace sss {

class GpuRenderer {
public:
    // Uploads the scene once; throws sss::Error when the scene does not fit the device
    // (a buffer over max_storage_buffer_bytes()).
    GpuRenderer(VulkanCompute& vk, const GpuSceneData& scene);
    // Reads integrator, spp, seed, max_bounces, record_paths and the benchmark knobs
    // gpu_batch (samples per pixel per dispatch; 0: one, then as many as take about a
    // quarter of a second, at most 4x the last and about 2^20 paths) and gpu_lanes
    // (invocations per dispatch, each rendering every lanes-th path; 0: one path each).
    // No result depends on the knobs. The rest was baked into the scene.
    RenderResult render(const RenderOptions& options, const ProgressFn& progress = {});

private:
    VulkanCompute& vk_;
    int width_, height_;
    bool has_model_;
    bool st_steps_;  // "st" can take a step somewhere; else it runs the "pt" kernel
    VulkanCompute::BufferId header_, nodes_, triangles_, grid_, model_, cut_model_;
    VulkanCompute::PipelineId pt_, st_;
    // Per-path outputs, reused across renders (room for out_paths_ paths).
    VulkanCompute::BufferId radiance_ = -1, counts_ = -1;
    size_t out_paths_ = 0;
};

// For tests of the shaders' parts against the CPU's:
// n sphere steps from packed decoders (pack_gpu_model) for per-step sigma[i], g[i] and
// phi[i] (nullptr: 1), step i drawn from Rng(seed, i), as ScatteringModel::sample_batch
// draws them: per step (N, cos_theta, alpha, beta, X, 0, W, 0), with EventGen's event X,
// W if with_event (else X = 0, W = +z). *gpu_seconds (if given) receives the dispatch's
// GPU time.
std::vector<float> gpu_sample_steps(VulkanCompute& vk, const std::vector<float>& model,
                                    const float* sigma, const float* g, const float* phi,
                                    size_t n, uint64_t seed, bool with_event,
                                    double* gpu_seconds = nullptr);
// n cut sphere steps from packed cut decoders (pack_gpu_cut_model) for per-step sigma[i],
// g[i], h[i] and mu0[i], step i drawn from Rng(seed, i) as the binding's cut_steps draws
// them: per step (N, through_plane (1/0), 0, 0, exit_pos, 0, exit_dir, 0) in the walk's
// frame.
std::vector<float> gpu_sample_cut_steps(VulkanCompute& vk,
                                        const std::vector<float>& model,
                                        const float* sigma, const float* g,
                                        const float* h, const float* mu0, size_t n,
                                        uint64_t seed);
// Closest hits of n rays (origin xyz, 0, unit direction xyz, tfar: 8 floats each) in the
// scene's BVH: (t or -1, mesh index, normal x, normal y) per ray.
std::vector<float> gpu_trace_rays(VulkanCompute& vk, const GpuSceneData& scene,
                                  const float* rays, size_t n);

}  // namespace sss

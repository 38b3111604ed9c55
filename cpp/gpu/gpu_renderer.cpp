#include "gpu/gpu_renderer.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "core/check.h"
#include "render/scheduler.h"
#include "shared/sphere_step.h"

namespace sss {

namespace {

static const uint32_t kRenderPt[] =
#include "shaders/render_pt.spv.h"
    ;
static const uint32_t kRenderSt[] =
#include "shaders/render_st.spv.h"
    ;

static const uint32_t kSampleSteps[] =
#include "shaders/sample_steps.spv.h"
    ;
static const uint32_t kSampleCutSteps[] =
#include "shaders/sample_cut_steps.spv.h"
    ;
static const uint32_t kTraceRays[] =
#include "shaders/trace_rays.spv.h"
    ;

constexpr uint32_t kGroup = 64;  // render.glsl's workgroup size
// The wall time a dispatch aims at when the batch is not fixed
// (RenderOptions::gpu_batch): progress and Ctrl-C are answered between dispatches.
constexpr double kDispatchSeconds = 0.25;

template <class T>
VulkanCompute::BufferId upload_array(VulkanCompute& vk, const std::vector<T>& v,
                                     const std::string& source, const char* what) {
    const size_t bytes = std::max<size_t>(4, v.size() * sizeof(T));
    if (bytes > vk.max_storage_buffer_bytes())
        fail(source, ": the ", what, " take ", bytes, " bytes, more than ",
             vk.device_name(), " binds in one buffer (", vk.max_storage_buffer_bytes(),
             ")");
    VulkanCompute::BufferId b = vk.create_buffer(bytes);
    if (!v.empty()) vk.upload(b, v.data(), v.size() * sizeof(T));
    return b;
}

// The packed decoders as a uniform block of `floats` floats, zeros after them.
VulkanCompute::BufferId upload_uniform_block(VulkanCompute& vk,
                                             const std::vector<float>& v, int floats,
                                             const std::string& source,
                                             const char* what) {
    if (v.size() > size_t(floats))
        fail(source, ": the ", what, " take ", v.size(),
             " floats; the GPU path holds at most ", floats);
    std::vector<float> padded(size_t(floats), 0.f);
    std::copy(v.begin(), v.end(), padded.begin());
    return upload_array(vk, padded, source, what);
}

// Whether "st" can take a step anywhere in the scene. Sphere steps: some medium's grid
// bound times its spectral_switch_extinction reaches the threshold (the bound at a point
// is at most the largest value of the grid's nodes), as SphereTracing::can_step.
// Cut steps: some medium has plane certificates.
bool can_take_steps(const GpuSceneData& scene) {
    const GpuSceneHeader& h = scene.header;
    for (uint32_t i = 0; i < h.counts[0]; ++i)
        if (!scene.cut_model.empty() && h.cut_grids[i].n[0] > 0) return true;
    for (uint32_t i = 0; i < h.counts[0]; ++i) {
        const GpuGrid& g = h.grids[i];
        if (g.n[0] == 0) continue;
        const size_t first = size_t(g.n[3]), count = size_t(g.n[0]) * g.n[1] * g.n[2];
        if (first + count > scene.floats.size()) return true;  // cannot tell
        const float r = *std::max_element(scene.floats.begin() + first,
                                          scene.floats.begin() + first + count);
        const float* s = h.shapes[i].sigma_t;
        if (spectral_switch_extinction(Vec3(s[0], s[1], s[2])) * r >= h.params[1] + s[3])
            return true;  // + clearance
    }
    return false;
}

// The render shaders' specialization constants: the decoders' shapes (model.glsl, ids
// 0-11), whether the shaders sample lights (render.glsl's NEE, id 12), the cut decoders'
// shapes (cut_model.glsl, ids 13-20) and whether cut steps are taken (CUTS, id 21).
std::vector<int32_t> gpu_render_constants(const GpuSceneData& scene) {
    std::vector<int32_t> c = gpu_model_constants(scene.model);
    c.push_back(scene.header.lighting[1] != 0 ? 1 : 0);
    for (int32_t v : gpu_cut_model_constants(scene.cut_model)) c.push_back(v);
    c.push_back(scene.cut_model.empty() ? 0 : 1);
    return c;
}

}  // namespace

GpuRenderer::GpuRenderer(VulkanCompute& vk, const GpuSceneData& scene)
    : vk_(vk),
      width_(scene.width()),
      height_(scene.height()),
      has_model_(!scene.model.empty()),
      st_steps_(can_take_steps(scene)) {
    header_ = vk.create_buffer(sizeof(GpuSceneHeader));
    vk.upload(header_, &scene.header, sizeof(GpuSceneHeader));
    nodes_ = upload_array(vk, scene.nodes, scene.source, "BVH nodes");
    triangles_ = upload_array(vk, scene.triangles, scene.source, "triangles");
    grid_ = upload_array(vk, scene.floats, scene.source, "distance grids");
    // The uniform blocks of model.glsl and cut_model.glsl (zeros without cut steps).
    model_ =
        upload_uniform_block(vk, scene.model, kGpuModelFloats, scene.source, "decoders");
    cut_model_ = upload_uniform_block(vk, scene.cut_model, kGpuCutModelFloats,
                                      scene.source, "cut decoders");
    // Specialization constants (gpu_render_constants).
    const std::vector<int32_t> constants = gpu_render_constants(scene);
    constexpr uint32_t kUniformBlocks = (1u << 4) | (1u << 7);  // bindings 4 and 7
    pt_ = vk.create_pipeline(kRenderPt, sizeof(kRenderPt) / 4, 8, sizeof(GpuRenderPush),
                             constants, kUniformBlocks);
    st_ = vk.create_pipeline(kRenderSt, sizeof(kRenderSt) / 4, 8, sizeof(GpuRenderPush),
                             constants, kUniformBlocks);
}

RenderResult GpuRenderer::render(const RenderOptions& opt, const ProgressFn& progress) {
    check_render_options(opt, "");
    if (opt.gpu_lanes < 0) fail("lanes must be >= 0 (0: automatic), got ", opt.gpu_lanes);
    if (opt.rows != 0)
        fail("a band of rows is CPU only (backend 'vulkan' renders whole images)");
    const bool st = opt.integrator == "st";
    const size_t W = size_t(width_), H = size_t(height_), pixels = W * H;
    if (opt.record_paths && uint64_t(opt.spp) * pixels > kMaxRecordedPaths)
        fail("record_paths keeps at most 2^27 paths; ", opt.spp, " spp x ", pixels,
             " pixels are more");
    // A GPU is full at about 2^20 paths per dispatch: the most samples per pixel one
    // dispatch takes, unless the options fix it.
    int batch = opt.gpu_batch > 0 ? opt.gpu_batch
                                  : int(std::max<size_t>(1, (size_t(1) << 20) / pixels));
    batch = std::min(batch, opt.spp);
    const size_t max_paths = vk_.max_storage_buffer_bytes() / 16;
    if (size_t(batch) * pixels > max_paths)
        batch = int(std::max<size_t>(1, max_paths / pixels));
    if (pixels > max_paths)
        fail("a ", width_, " x ", height_, " image is more than ", vk_.device_name(),
             " can render in one dispatch (", max_paths, " paths)");

    // The output buffers live as long as the device (VulkanCompute frees none before):
    // kept and reused by later renders, grown only when a batch needs more.
    if (size_t(batch) * pixels > out_paths_) {
        out_paths_ = size_t(batch) * pixels;
        radiance_ = vk_.create_buffer(out_paths_ * 16);
        counts_ = vk_.create_buffer(out_paths_ * 8);
    }
    std::vector<float> rad(size_t(batch) * pixels * 4);
    std::vector<uint32_t> cnt(size_t(batch) * pixels * 2);
    PathRecord paths(opt.record_paths ? size_t(opt.spp) * pixels : 0);
    double gpu_seconds = 0.0;

    // One pass is one dispatch of samples [s0, s1) of every pixel.
    auto dispatch = [&](const TileWork& w, Film& film, const std::atomic<bool>&) {
        const size_t paths_now = size_t(w.s1 - w.s0) * pixels;
        GpuRenderPush push{uint32_t(opt.seed), uint32_t(opt.seed >> 32), uint32_t(w.s0),
                           int32_t(opt.max_bounces), uint32_t(paths_now)};
        // One lane per path unless asked otherwise, and no more than one dispatch holds.
        const size_t lanes =
            std::min({opt.gpu_lanes > 0 ? size_t(opt.gpu_lanes) : paths_now, paths_now,
                      size_t(vk_.max_workgroups_x()) * kGroup});
        vk_.fill_zero(counts_);
        // Where no step can happen "st" is "pt", path for path: the lighter kernel runs.
        gpu_seconds += vk_.run(
            st && st_steps_ ? st_ : pt_,
            {header_, nodes_, triangles_, grid_, model_, radiance_, counts_, cut_model_},
            &push, sizeof(push), uint32_t((lanes + kGroup - 1) / kGroup));
        vk_.download(radiance_, rad.data(), paths_now * 16);
        vk_.download(counts_, cnt.data(), paths_now * 8);
        size_t unfinished = 0;
        for (size_t i = 0; i < paths_now; ++i) {
            unfinished += (cnt[2 * i + 1] & kGpuWritten) == 0;
            cnt[2 * i + 1] &= ~kGpuWritten;
        }
        if (unfinished > 0)
            fail(unfinished, " of ", paths_now,
                 " paths did not end on the Vulkan device '", vk_.device_name(), "'",
                 vk_.is_software()
                     ? ". Mesa's lavapipe stops all loops of a shader invocation after "
                       "65535 iterations, which long paths need (thousands of scattering "
                       "events, or of reflections inside glass or between surfaces): "
                       "render on the CPU (backend 'cpu') or on a GPU"
                     : "");
        for (int k = 0; k < w.s1 - w.s0; ++k)
            for (size_t p = 0; p < pixels; ++p) {
                const size_t at = size_t(k) * pixels + p;
                film.add_sample(p, &rad[4 * at], cnt[2 * at], cnt[2 * at + 1]);
                if (paths.on())
                    paths.set(size_t(w.s0 - opt.first_sample + k) * pixels + p,
                              cnt[2 * at], cnt[2 * at + 1]);
            }
        return true;
    };

    // The whole image is one tile, rendered on the calling thread (Vulkan's queue is not
    // shared between threads); progress, Ctrl-C and the time limit are answered between
    // dispatches. Without a fixed batch the first dispatch renders one sample per pixel
    // and later ones grow, at most 4x each, towards kDispatchSeconds at the speed
    // measured so far: a slow device (lavapipe, or a GPU on a dense medium) would
    // otherwise hold them for as long as 2^20 paths take (20 s on lavapipe).
    ScheduleOptions schedule_options;
    schedule_options.width = width_;
    schedule_options.height = height_;
    schedule_options.spp = opt.spp;
    schedule_options.first_sample = opt.first_sample;
    schedule_options.tile = std::max(width_, height_);
    schedule_options.threads = 0;
    schedule_options.time_limit = opt.time_limit;
    PassPolicy& passes = schedule_options.passes;
    passes.max_size = batch;
    if (opt.gpu_batch > 0) {
        passes.first = batch;
        passes.growth = 1;
    } else {
        passes.first = 1;
        passes.growth = 4;
        passes.target_seconds = kDispatchSeconds;
    }
    Scheduled done = schedule(schedule_options, dispatch, progress);

    RenderResult r;
    r.width = width_;
    r.height = height_;
    r.device = vk_.device_name();
    r.cancelled = done.cancelled;
    r.time_limit_reached = done.time_limit_reached;
    r.seconds = done.seconds;
    r.gpu_seconds = gpu_seconds;
    done.film.finish(done.spp, r);
    paths.finish(size_t(done.spp) * pixels, r);
    if (opt.keep_film) r.film = std::move(done.film);
    return r;
}

std::vector<float> gpu_sample_steps(VulkanCompute& vk, const std::vector<float>& model,
                                    const float* sigma, const float* g, const float* phi,
                                    size_t n, uint64_t seed, bool with_event,
                                    double* gpu_seconds) {
    if (n == 0) return {};
    std::vector<float> in(4 * n), out(12 * n);
    for (size_t i = 0; i < n; ++i) {
        in[4 * i] = sigma[i], in[4 * i + 1] = g[i];
        in[4 * i + 2] = phi ? phi[i] : 1.f;
    }
    auto m =
        upload_uniform_block(vk, model, kGpuModelFloats, "gpu_sample_steps", "decoders");
    auto bin = upload_array(vk, in, "gpu_sample_steps", "inputs");
    auto bout = vk.create_buffer(out.size() * 4);
    auto pipe = vk.create_pipeline(kSampleSteps, sizeof(kSampleSteps) / 4, 3, 16,
                                   gpu_model_constants(model), 1u);
    const uint32_t push[4] = {uint32_t(seed), uint32_t(seed >> 32), uint32_t(n),
                              with_event ? 1u : 0u};
    const double t =
        vk.run(pipe, {m, bin, bout}, push, sizeof(push), uint32_t((n + 63) / 64));
    if (gpu_seconds) *gpu_seconds = t;
    vk.download(bout, out.data(), out.size() * 4);
    return out;
}

std::vector<float> gpu_sample_cut_steps(VulkanCompute& vk,
                                        const std::vector<float>& model,
                                        const float* sigma, const float* g,
                                        const float* h, const float* mu0, size_t n,
                                        uint64_t seed) {
    if (n == 0) return {};
    std::vector<float> in(4 * n), out(12 * n);
    for (size_t i = 0; i < n; ++i)
        in[4 * i] = sigma[i], in[4 * i + 1] = g[i], in[4 * i + 2] = h[i],
               in[4 * i + 3] = mu0[i];
    auto m = upload_uniform_block(vk, model, kGpuCutModelFloats, "gpu_sample_cut_steps",
                                  "cut decoders");
    auto bin = upload_array(vk, in, "gpu_sample_cut_steps", "inputs");
    auto bout = vk.create_buffer(out.size() * 4);
    // cut_model.glsl's shapes are constants 13-20, as in the render shaders.
    std::vector<int32_t> constants = gpu_model_constants({});
    constants.push_back(0);
    for (int32_t v : gpu_cut_model_constants(model)) constants.push_back(v);
    auto pipe = vk.create_pipeline(kSampleCutSteps, sizeof(kSampleCutSteps) / 4, 3, 12,
                                   constants, 1u);
    const uint32_t push[3] = {uint32_t(seed), uint32_t(seed >> 32), uint32_t(n)};
    vk.run(pipe, {m, bin, bout}, push, sizeof(push), uint32_t((n + 63) / 64));
    vk.download(bout, out.data(), out.size() * 4);
    return out;
}

std::vector<float> gpu_trace_rays(VulkanCompute& vk, const GpuSceneData& scene,
                                  const float* rays, size_t n) {
    if (n == 0) return {};
    std::vector<float> in(rays, rays + 8 * n), out(4 * n);
    auto header = vk.create_buffer(sizeof(GpuSceneHeader));
    vk.upload(header, &scene.header, sizeof(GpuSceneHeader));
    auto nodes = upload_array(vk, scene.nodes, scene.source, "BVH nodes");
    auto tris = upload_array(vk, scene.triangles, scene.source, "triangles");
    auto grid = upload_array(vk, scene.floats, scene.source, "distance grids");
    auto bin = upload_array(vk, in, "gpu_trace_rays", "rays");
    auto bout = vk.create_buffer(out.size() * 4);
    auto pipe = vk.create_pipeline(kTraceRays, sizeof(kTraceRays) / 4, 6, 4);
    const uint32_t push = uint32_t(n);
    vk.run(pipe, {header, nodes, tris, grid, bin, bout}, &push, sizeof(push),
           uint32_t((n + 63) / 64));
    vk.download(bout, out.data(), out.size() * 4);
    return out;
}

}  // namespace sss

#include "render/renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>

#include "core/check.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "render/camera.h"
#include "render/pt.h"
#include "render/scheduler.h"
#include "render/sphere_tracing.h"

namespace sss {

namespace {

constexpr int kTile = 16;
// Paths "st" keeps in flight per thread: the sphere steps they wait for are sampled
// together (SphereTracing::sample_group), which is what makes a step cheap.
constexpr int kPathsInFlight = SphereTracing::kMaxGroup;

// Passes of 1, 2, 4, ... samples per pixel up to spp/16, then spp/16 each: an interrupted
// render has a uniform, early image and loses at most 1/16 of the work. With a time
// limit, a pass after the first is also at most what about 1/16 of the limit renders at
// the speed measured so far. Without one the passes, and so the image, do not depend on
// timing.
PassPolicy cpu_passes(const RenderOptions& opt) {
    PassPolicy p;
    p.first = 1;
    p.growth = 2;
    p.max_size = std::max(1, (opt.spp + 15) / 16);
    if (opt.time_limit > 0.0) p.target_seconds = opt.time_limit / 16;
    return p;
}

// Work items 0 .. count-1 (camera_ray(item, state) starts one, record(item, sample)
// takes its result), traced kPathsInFlight at a time: each runs until it ends or waits
// for a sphere step; the waiting steps are sampled together, and a path that ends makes
// room for the next item. Every path draws from its own stream, so the results do not
// depend on the grouping. Adds the time spent sampling steps to step_seconds. Returns
// false if cancelled before the end.
template <class Start, class Record>
bool trace_in_flight(const PathTracer& tracer, const SphereTracing& st, int count,
                     Start&& camera_ray, Record&& record, const std::atomic<bool>& cancel,
                     double& step_seconds) {
    PathState slot[kPathsInFlight];
    int item[kPathsInFlight];
    bool busy[kPathsInFlight] = {};
    int next = 0;
    // Advances slot j (taking `step` if given) until its path waits for a step; paths
    // that end are recorded and replaced by the next item.
    auto run = [&](int j, const WorldSphereStep* step) {
        while (tracer.advance(slot[j], step)) {
            record(item[j], slot[j].out);
            step = nullptr;
            if (next >= count) {
                busy[j] = false;
                return;
            }
            item[j] = next++;
            camera_ray(item[j], slot[j]);
        }
    };
    for (int j = 0; j < kPathsInFlight && next < count; ++j) {
        busy[j] = true;
        item[j] = next++;
        camera_ray(item[j], slot[j]);
        run(j, nullptr);
    }
    const StepRequest* req[kPathsInFlight];
    Rng* rng[kPathsInFlight];
    WorldSphereStep step[kPathsInFlight];
    int waiting[kPathsInFlight];
    for (;;) {
        int n = 0;
        for (int j = 0; j < kPathsInFlight; ++j)
            if (busy[j]) {
                waiting[n] = j;
                req[n] = &slot[j].step;
                rng[n++] = &slot[j].rng;
            }
        if (n == 0) return true;
        if (cancel) return false;
        const auto t0 = std::chrono::steady_clock::now();
        st.sample_group(n, req, rng, step);
        step_seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        for (int k = 0; k < n; ++k) run(waiting[k], &step[k]);
    }
}

// Checks the options and that the paths fit record_paths.
void check_options(const Scene& scene, const RenderOptions& opt) {
    check_render_options(opt, scene.desc().source);
    const Camera& cam = scene.desc().camera;
    const uint64_t num_paths =
        uint64_t(cam.width) * uint64_t(cam.height) * uint64_t(opt.spp);
    if (opt.record_paths && num_paths > kMaxRecordedPaths)
        fail("record_paths keeps 8 bytes per path: ", cam.width, "x", cam.height,
             " pixels at ", opt.spp, " spp are ", num_paths, " paths (allowed: at most ",
             kMaxRecordedPaths, "); render fewer pixels or samples");
}

}  // namespace

RenderResult render(const Scene& scene, const RenderOptions& opt,
                    const ProgressFn& progress) {
    check_options(scene, opt);
    const Camera& cam = scene.desc().camera;
    const int W = cam.width, H = cam.height;
    std::unique_ptr<SphereTracing> sphere_tracing;
    if (opt.integrator == "st")
        sphere_tracing = std::make_unique<SphereTracing>(scene, opt.sphere_threshold,
                                                         opt.sphere_sampler, opt.models,
                                                         opt.nee, opt.step_nee);
    // Where no step can happen, "st" is "pt" path for path: trace it as "pt".
    const SphereTracing* stepper =
        sphere_tracing && sphere_tracing->may_step() ? sphere_tracing.get() : nullptr;
    const PathTracer tracer(scene, opt.max_bounces, opt.nee, stepper);
    const PinholeCamera camera(cam);
    PathRecord paths(opt.record_paths ? size_t(W) * H * opt.spp : 0);
    std::mutex step_mutex;
    double step_seconds = 0.0;  // summed over the tiles

    // Sample k of tile pixel i (in row order) is the tile's work item i * m + (k - s0).
    auto render_tile = [&](const TileWork& w, Film& film,
                           const std::atomic<bool>& cancel) {
        const int m = w.s1 - w.s0, items = w.pixels() * m;
        auto pixel = [&](int item, int& x, int& y) {
            x = w.x0 + (item / m) % w.width();
            y = w.y0 + (item / m) / w.width();
        };
        auto camera_ray = [&](int item, PathState& ps) {
            int x, y;
            pixel(item, x, y);
            Rng rng(opt.seed, uint64_t(y) * W + x, uint64_t(w.s0 + item % m));
            const float jx = rng.uniform(), jy = rng.uniform();
            tracer.start(ps, camera.origin(), camera.direction(x + jx, y + jy), rng);
        };
        auto record = [&](int item, const PathSample& ps) {
            if (paths.on()) {
                int x, y;
                pixel(item, x, y);
                paths.set((size_t(w.s0 + item % m) * H + y) * W + x, ps.scatter_events,
                          ps.sphere_steps);
            }
            film.add_sample(item / m, ps.radiance, ps.scatter_events, ps.sphere_steps);
        };
        if (stepper) {
            double seconds = 0.0;
            const bool complete = trace_in_flight(tracer, *stepper, items, camera_ray,
                                                  record, cancel, seconds);
            std::lock_guard<std::mutex> lock(step_mutex);
            step_seconds += seconds;
            return complete;
        }
        for (int i = 0; i < items; ++i) {
            if (i % m == 0 && cancel) return false;
            PathState ps;
            camera_ray(i, ps);
            tracer.advance(ps);
            record(i, ps.out);
        }
        return true;
    };

    ScheduleOptions schedule_options;
    schedule_options.width = W;
    schedule_options.height = H;
    schedule_options.spp = opt.spp;
    schedule_options.tile = kTile;
    schedule_options.threads = worker_threads(opt.threads);
    schedule_options.time_limit = opt.time_limit;
    schedule_options.passes = cpu_passes(opt);
    Scheduled done = schedule(schedule_options, render_tile, progress);

    RenderResult r;
    r.width = W;
    r.height = H;
    r.cancelled = done.cancelled;
    r.time_limit_reached = done.time_limit_reached;
    r.seconds = done.seconds;
    r.step_seconds = step_seconds;
    done.film.finish(done.spp, r);
    paths.finish(size_t(W) * H * done.spp, r);
    return r;
}

}  // namespace sss

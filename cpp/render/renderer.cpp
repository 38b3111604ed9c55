#include "render/renderer.h"

#include <algorithm>
#include <atomic>
#include <memory>

#include "core/check.h"
#include "core/parallel.h"
#include "render/camera.h"
#include "render/integrators/integrator.h"
#include "render/scheduler.h"

namespace sss {

namespace {

constexpr int kTile = 16;

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

// Checks the options and that the paths fit record_paths.
void check_options(const Scene& scene, const RenderOptions& opt) {
    check_render_options(opt, scene.desc().source);
    const Camera& cam = scene.desc().camera;
    const uint64_t num_paths =
        uint64_t(cam.width) * uint64_t(cam.height) * uint64_t(opt.spp);
    if (opt.first_row < 0 || opt.rows < 0 || opt.first_row + opt.rows > cam.height ||
        (opt.rows == 0 && opt.first_row != 0))
        fail("rows [", opt.first_row, ", ", opt.first_row + opt.rows,
             ") are not a band of the image's ", cam.height, " rows");
    if (opt.record_paths && num_paths > kMaxRecordedPaths)
        fail("record_paths keeps 8 bytes per path: ", cam.width, "x", cam.height,
             " pixels at ", opt.spp, " spp are ", num_paths, " paths (allowed: at most ",
             kMaxRecordedPaths, "); render fewer pixels or samples",
             opt.time_limit > 0
                 ? " (under a time limit spp is the most the render takes, "
                   "unlimited unless given: give spp)"
                 : "");
}

}  // namespace

RenderResult render(const Scene& scene, const RenderOptions& opt,
                    const ProgressFn& progress) {
    check_options(scene, opt);
    const Camera& cam = scene.desc().camera;
    const int W = cam.width, H = cam.height;
    const PinholeCamera camera(cam);
    PathRecord paths(opt.record_paths ? size_t(W) * H * opt.spp : 0);
    const std::unique_ptr<Integrator> integrator =
        integrator_kind(opt.integrator).make({scene, opt, camera, paths});
    auto render_tile = [&](const TileWork& w, Film& film,
                           const std::atomic<bool>& cancel) {
        return integrator->render_tile(w, film, cancel);
    };

    ScheduleOptions schedule_options;
    schedule_options.width = W;
    schedule_options.height = H;
    schedule_options.spp = opt.spp;
    schedule_options.first_sample = opt.first_sample;
    schedule_options.row0 = opt.first_row;
    schedule_options.row1 = opt.rows > 0 ? opt.first_row + opt.rows : 0;
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
    r.step_seconds = integrator->step_seconds();
    r.warnings = integrator->warnings();
    done.film.finish(done.spp, r);
    paths.finish(size_t(W) * H * done.spp, r);
    if (opt.keep_film) r.film = std::move(done.film);
    return r;
}

SphereStepCheck check_sphere_steps(const Scene& scene, const RenderOptions& options) {
    const SphereTracing st(scene, options.sphere_threshold, options.sphere_sampler,
                           options.models, options.nee, options.step_nee);
    SphereStepCheck check;
    for (int i = 0; i < scene.num_shapes(); ++i) check.steps.push_back(st.can_step(i));
    check.warnings = st.warnings();
    return check;
}

}  // namespace sss

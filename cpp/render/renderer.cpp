#include "render/renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "core/check.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "render/camera.h"
#include "render/pt.h"
#include "render/sphere_tracing.h"

namespace sss {

namespace {

constexpr int kTile = 16;
// Paths "st" keeps in flight per thread: the sphere steps they wait for are sampled
// together (SphereTracing::sample_group), which is what makes a step cheap.
constexpr int kPathsInFlight = SphereTracing::kMaxGroup;

// Passes a tile may run ahead of the film (the passes every tile has finished).
constexpr int kPassesAhead = 4;

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

}  // namespace

RenderResult render(const Scene& scene, const RenderOptions& opt,
                    const ProgressFn& progress) {
    const Camera& cam = scene.desc().camera;
    const int W = cam.width, H = cam.height;
    if (opt.spp <= 0) fail("spp must be >= 1, got ", opt.spp);
    if (opt.threads < 0) fail("threads must be >= 0 (0 = all cores), got ", opt.threads);
    if (!(opt.time_limit >= 0.0))
        fail("time_limit must be a number > 0 (seconds; 0: none), got ", opt.time_limit);
    if (opt.integrator != "pt" && opt.integrator != "st")
        fail(scene.desc().source, ": integrator '", opt.integrator,
             "' is not available (allowed: \"pt\", \"st\")");
    std::unique_ptr<SphereTracing> sphere_tracing;
    if (opt.integrator == "st") {
        if (opt.max_bounces != -1)
            fail("max_bounces ", opt.max_bounces,
                 " is not supported by integrator 'st' (allowed: -1): a sphere "
                 "step stands for many scattering events at once");
        sphere_tracing = std::make_unique<SphereTracing>(scene, opt.sphere_threshold,
                                                         opt.sphere_sampler, opt.models,
                                                         opt.nee, opt.step_nee);
    }

    const uint64_t num_paths = uint64_t(W) * uint64_t(H) * uint64_t(opt.spp);
    if (opt.record_paths && num_paths > kMaxRecordedPaths)
        fail("record_paths keeps 8 bytes per path: ", W, "x", H, " pixels at ", opt.spp,
             " spp are ", num_paths, " paths (allowed: at most ", kMaxRecordedPaths,
             "); render fewer pixels or samples");
    std::vector<uint32_t> path_events(opt.record_paths ? num_paths : 0),
        path_steps(opt.record_paths ? num_paths : 0);

    const int tiles_x = (W + kTile - 1) / kTile, tiles_y = (H + kTile - 1) / kTile;
    const int num_tiles = tiles_x * tiles_y;
    const size_t pixels = size_t(W) * H;
    const bool timed = opt.time_limit > 0.0;
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    };
    std::atomic<int64_t> done_samples{0};  // traced, merged or not

    // Passes of 1, 2, 4, ... samples per pixel up to spp/16, then spp/16 each: an
    // interrupted render has a uniform, early image and loses at most 1/16 of the work.
    // With a time limit, a pass after the first is also at most what about 1/16 of the
    // limit renders at the speed measured so far. Passes are made as the tiles reach
    // them; pass p is samples [pass_starts[p], pass_starts[p + 1]).
    std::mutex schedule_mutex;
    std::vector<int> pass_starts{0};
    const int chunk = std::max(1, (opt.spp + 15) / 16);
    int last_size = 0;
    // The samples of pass p, or false when the passes before it hold all spp.
    auto pass_bounds = [&](int p, int& s0, int& s1) {
        std::lock_guard<std::mutex> lock(schedule_mutex);
        while (int(pass_starts.size()) <= p + 1 && pass_starts.back() < opt.spp) {
            int size = last_size == 0 ? 1 : std::min(2 * last_size, chunk);
            const double spp_done = double(done_samples) / double(pixels), t = elapsed();
            if (timed && spp_done > 0 && t > 0)
                size = int(
                    std::clamp(spp_done / t * opt.time_limit / 16, 1.0, double(size)));
            last_size = size;
            pass_starts.push_back(std::min(opt.spp, pass_starts.back() + size));
        }
        if (int(pass_starts.size()) <= p + 1) return false;
        s0 = pass_starts[p];
        s1 = pass_starts[p + 1];
        return true;
    };

    // The film. A finished (tile, pass) waits in `pending` until every tile has finished
    // that pass; whole passes are then added in order. So every pixel holds the same
    // samples (an interrupted render too), and the floating-point sums do not depend on
    // scheduling: the image is bit-identical for any thread count.
    Film film(pixels);
    std::mutex film_mutex;
    std::condition_variable film_changed;
    std::map<int, std::vector<Film>> pending;  // pass -> its finished tiles
    std::map<int, int> tiles_finished;         // pass -> how many
    int passes_merged = 0;
    auto tile_rect = [&](int tile, int& x0, int& y0, int& x1, int& y1) {
        x0 = (tile % tiles_x) * kTile;
        y0 = (tile / tiles_x) * kTile;
        x1 = std::min(W, x0 + kTile);
        y1 = std::min(H, y0 + kTile);
    };
    // Under film_mutex: adds every pass all tiles have finished, in order.
    auto merge_finished_passes = [&] {
        for (auto it = pending.begin();
             it != pending.end() && it->first == passes_merged &&
             tiles_finished[passes_merged] == num_tiles;
             it = pending.erase(it)) {
            for (int tile = 0; tile < num_tiles; ++tile) {
                int x0, y0, x1, y1;
                tile_rect(tile, x0, y0, x1, y1);
                for (int y = y0, i = 0; y < y1; ++y)
                    for (int x = x0; x < x1; ++x, ++i)
                        film.add_pixel(size_t(y) * W + x, it->second[tile], i);
            }
            tiles_finished.erase(passes_merged);
            ++passes_merged;
            film_changed.notify_all();
        }
    };

    PinholeCamera camera(cam);
    // Where no step can happen, "st" is "pt" path for path: trace it as "pt".
    const SphereTracing* stepper =
        sphere_tracing && sphere_tracing->may_step() ? sphere_tracing.get() : nullptr;
    PathTracer tracer(scene, opt.max_bounces, opt.nee, stepper);
    std::atomic<int64_t> next_task{0};
    std::atomic<bool> cancel{false};
    std::mutex error_mutex;
    std::string error;
    double step_seconds = 0.0;  // summed over the threads, each under error_mutex
    const double total_samples = double(pixels) * opt.spp;

    // Stops every worker, also those waiting for the film.
    auto stop = [&] {
        cancel = true;
        std::lock_guard<std::mutex> lock(film_mutex);
        film_changed.notify_all();
    };

    auto worker = [&]() {
        double my_step_seconds = 0.0;
        for (int64_t task; !cancel;) {
            task = next_task.fetch_add(1);
            // Tasks go pass by pass: task = pass * num_tiles + tile.
            const int pass = int(task / num_tiles), tile = int(task % num_tiles);
            int s0, s1;
            if (!pass_bounds(pass, s0, s1)) break;
            {
                // At most kPassesAhead passes wait for a slow tile: bounded memory.
                std::unique_lock<std::mutex> lock(film_mutex);
                film_changed.wait(
                    lock, [&] { return pass < passes_merged + kPassesAhead || cancel; });
            }
            if (cancel) break;
            int x0, y0, x1, y1;
            tile_rect(tile, x0, y0, x1, y1);
            const int n = (x1 - x0) * (y1 - y0);
            Film t(n);  // the tile's pixels in row order
            // Sample k of tile pixel i (in row order) is work item i * m + (k - s0).
            const int m = s1 - s0;
            auto camera_ray = [&](int item, PathState& ps) {
                const int i = item / m, k = s0 + item % m;
                const int x = x0 + i % (x1 - x0), y = y0 + i / (x1 - x0);
                Rng rng(opt.seed, uint64_t(y) * W + x, uint64_t(k));
                float jx = rng.uniform(), jy = rng.uniform();
                tracer.start(ps, camera.origin(), camera.direction(x + jx, y + jy), rng);
            };
            auto record = [&](int item, const PathSample& ps) {
                const int i = item / m;
                if (opt.record_paths) {
                    const int x = x0 + i % (x1 - x0), y = y0 + i / (x1 - x0);
                    const size_t at = (size_t(s0 + item % m) * H + y) * W + x;
                    path_events[at] = ps.scatter_events;
                    path_steps[at] = ps.sphere_steps;
                }
                t.add_sample(i, ps.radiance, ps.scatter_events, ps.sphere_steps);
            };
            bool complete = true;
            try {
                if (stepper)
                    complete = trace_in_flight(tracer, *stepper, n * m, camera_ray,
                                               record, cancel, my_step_seconds);
                else
                    for (int i = 0; i < n * m && complete; ++i) {
                        if (i % m == 0 && cancel) {
                            complete = false;
                            break;
                        }
                        PathState ps;
                        camera_ray(i, ps);
                        tracer.advance(ps);
                        record(i, ps.out);
                    }
                done_samples += n * m;
            } catch (const std::exception& e) {
                {
                    std::lock_guard<std::mutex> lock(error_mutex);
                    if (error.empty()) error = e.what();
                }
                stop();
                complete = false;
            }
            if (!complete) break;
            std::lock_guard<std::mutex> lock(film_mutex);
            std::vector<Film>& row = pending[pass];
            if (row.empty()) row.resize(num_tiles, Film(0));
            row[tile] = std::move(t);
            ++tiles_finished[pass];
            merge_finished_passes();
        }
        std::lock_guard<std::mutex> lock(error_mutex);
        step_seconds += my_step_seconds;
    };

    // Threads of its own, not oneTBB's pool (core/parallel.h): the workers block while
    // they are kPassesAhead passes ahead of the film, and the calling thread must stay
    // free to report progress and answer Ctrl-C (Python checks signals on it) about ten
    // times a second, which no work item is short enough to allow; TBB's pool counts the
    // calling thread as one of its workers, so its own workers alone would leave a core
    // idle.
    const int threads = worker_threads(opt.threads);
    std::vector<std::thread> pool;
    std::atomic<int> running{threads};
    std::mutex done_mutex;
    std::condition_variable done_cv;
    for (int t = 0; t < threads; ++t)
        pool.emplace_back([&] {
            worker();
            std::lock_guard<std::mutex> lock(done_mutex);
            --running;
            done_cv.notify_all();
        });
    // The calling thread reports progress, relays cancellation and keeps the time limit
    // (once the first pass is in: a time-limited render has at least one sample a pixel).
    bool user_cancelled = false, time_up = false;
    {
        std::unique_lock<std::mutex> lock(done_mutex);
        while (running > 0) {
            double wait = 0.1;
            if (timed) wait = std::clamp(opt.time_limit - elapsed(), 0.001, wait);
            done_cv.wait_for(lock, std::chrono::duration<double>(wait));
            if (running == 0) break;
            lock.unlock();
            if (timed && !time_up && !user_cancelled && elapsed() >= opt.time_limit) {
                std::lock_guard<std::mutex> film_lock(film_mutex);
                time_up = passes_merged > 0;
            }
            if (time_up) stop();
            if (progress && !user_cancelled && !time_up) {
                double f = done_samples / total_samples;
                if (timed) f = std::max(f, elapsed() / opt.time_limit);
                if (!progress(std::min(1.0, f))) {
                    user_cancelled = true;
                    stop();
                }
            }
            lock.lock();
        }
    }
    for (auto& t : pool) t.join();
    if (!error.empty()) fail(error);
    if (progress && !user_cancelled) progress(1.0);

    RenderResult r;
    r.width = W;
    r.height = H;
    r.cancelled = user_cancelled;
    r.time_limit_reached = time_up;
    r.seconds = elapsed();
    r.step_seconds = step_seconds;
    film.finish(pass_starts[passes_merged], r);
    if (opt.record_paths) {
        // Samples traced but not merged (cancelled) are not among the samples: clear
        // them.
        std::fill(path_events.begin() + int64_t(r.spp) * int64_t(pixels),
                  path_events.end(), 0u);
        std::fill(path_steps.begin() + int64_t(r.spp) * int64_t(pixels), path_steps.end(),
                  0u);
        r.path_events = std::move(path_events);
        r.path_steps = std::move(path_steps);
    }
    return r;
}

}  // namespace sss

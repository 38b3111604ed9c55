#include "render/renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

#include "core/check.h"
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

struct TileState {
    std::mutex mutex;
    std::condition_variable merged;
    int passes_merged = 0;
};

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
    // Passes of 1, 2, 4, ... samples per pixel up to spp/16, then spp/16 each: an
    // interrupted render has a uniform, early image and loses at most 1/16 of the work.
    std::vector<int> pass_starts{0};
    const int chunk = std::max(1, (opt.spp + 15) / 16);
    for (int size = 1; pass_starts.back() < opt.spp; size = std::min(2 * size, chunk))
        pass_starts.push_back(std::min(opt.spp, pass_starts.back() + size));
    const int num_passes = int(pass_starts.size()) - 1;
    auto pass_begin = [&](int p) { return pass_starts[p]; };
    const int64_t num_tasks = int64_t(num_tiles) * num_passes;

    std::vector<double> sum(size_t(W) * H * 3, 0.0), sum_sq(size_t(W) * H * 3, 0.0);
    std::vector<uint64_t> events(size_t(W) * H, 0), steps(size_t(W) * H, 0);
    std::vector<uint32_t> count(size_t(W) * H, 0);
    std::vector<TileState> tiles(num_tiles);

    PinholeCamera camera(cam);
    // Where no step can happen, "st" is "pt" path for path: trace it as "pt".
    const SphereTracing* stepper =
        sphere_tracing && sphere_tracing->may_step() ? sphere_tracing.get() : nullptr;
    PathTracer tracer(scene, opt.max_bounces, opt.nee, stepper);
    std::atomic<int64_t> next_task{0}, done_samples{0};
    std::atomic<bool> cancel{false};
    std::mutex error_mutex;
    std::string error;
    double step_seconds = 0.0;  // summed over the threads, each under error_mutex
    const double total_samples = double(W) * H * opt.spp;

    auto worker = [&]() {
        double my_step_seconds = 0.0;
        std::vector<double> s, s2;
        std::vector<uint64_t> ev, st;
        for (int64_t task; !cancel && (task = next_task.fetch_add(1)) < num_tasks;) {
            const int pass = int(task / num_tiles), tile = int(task % num_tiles);
            const int x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
            const int x1 = std::min(W, x0 + kTile), y1 = std::min(H, y0 + kTile);
            const int s0 = pass_begin(pass), s1 = pass_begin(pass + 1);
            const int n = (x1 - x0) * (y1 - y0);
            s.assign(size_t(n) * 3, 0.0);
            s2.assign(size_t(n) * 3, 0.0);
            ev.assign(size_t(n), 0);
            st.assign(size_t(n), 0);
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
                for (int c = 0; c < 3; ++c) {
                    double v = ps.radiance[c];
                    s[3 * i + c] += v;
                    s2[3 * i + c] += v * v;
                }
                ev[i] += ps.scatter_events;
                st[i] += ps.sphere_steps;
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
                std::lock_guard<std::mutex> lock(error_mutex);
                if (error.empty()) error = e.what();
                cancel = true;
                complete = false;
            }
            // Merge in pass order so the floating-point sums do not depend on scheduling.
            TileState& ts = tiles[tile];
            std::unique_lock<std::mutex> lock(ts.mutex);
            ts.merged.wait(lock, [&] { return ts.passes_merged == pass || cancel; });
            if (!complete || ts.passes_merged != pass) {
                ts.merged.notify_all();
                continue;
            }
            for (int y = y0, i = 0; y < y1; ++y)
                for (int x = x0; x < x1; ++x, ++i) {
                    size_t p = size_t(y) * W + x;
                    for (int c = 0; c < 3; ++c) {
                        sum[3 * p + c] += s[3 * i + c];
                        sum_sq[3 * p + c] += s2[3 * i + c];
                    }
                    events[p] += ev[i];
                    steps[p] += st[i];
                    count[p] += uint32_t(s1 - s0);
                }
            ts.passes_merged = pass + 1;
            ts.merged.notify_all();
        }
        std::lock_guard<std::mutex> lock(error_mutex);
        step_seconds += my_step_seconds;
    };

    auto start = std::chrono::steady_clock::now();
    int threads = opt.threads > 0
                      ? opt.threads
                      : int(std::max(1u, std::thread::hardware_concurrency()));
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
    // The calling thread reports progress and relays cancellation.
    bool user_cancelled = false;
    {
        std::unique_lock<std::mutex> lock(done_mutex);
        while (running > 0) {
            done_cv.wait_for(lock, std::chrono::milliseconds(100));
            if (progress && !user_cancelled) {
                lock.unlock();
                bool go_on = progress(std::min(1.0, done_samples / total_samples));
                lock.lock();
                if (!go_on) {
                    user_cancelled = true;
                    cancel = true;
                    for (TileState& ts : tiles) {
                        std::lock_guard<std::mutex> tl(ts.mutex);
                        ts.merged.notify_all();
                    }
                }
            }
        }
    }
    for (auto& t : pool) t.join();
    if (!error.empty()) fail(error);
    if (progress && !user_cancelled) progress(1.0);

    RenderResult r;
    r.width = W;
    r.height = H;
    r.cancelled = user_cancelled;
    r.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.step_seconds = step_seconds;
    r.image.assign(size_t(W) * H * 3, 0.f);
    r.variance.assign(size_t(W) * H * 3, 0.f);
    r.events.assign(size_t(W) * H, 0.f);
    r.sphere_steps.assign(size_t(W) * H, 0.f);
    r.samples = count;
    if (opt.record_paths) {
        // A pass traced but not merged (cancelled) is not among the samples: clear it.
        for (size_t p = 0; p < size_t(W) * H; ++p)
            for (size_t k = count[p]; k < size_t(opt.spp); ++k)
                path_events[k * W * H + p] = path_steps[k * W * H + p] = 0;
        r.path_events = std::move(path_events);
        r.path_steps = std::move(path_steps);
    }
    for (size_t p = 0; p < size_t(W) * H; ++p) {
        double n = count[p];
        r.total_paths += count[p];
        r.total_events += events[p];
        r.total_sphere_steps += steps[p];
        if (n == 0) continue;
        r.events[p] = float(double(events[p]) / n);
        r.sphere_steps[p] = float(double(steps[p]) / n);
        for (int c = 0; c < 3; ++c) {
            double mean = sum[3 * p + c] / n;
            r.image[3 * p + c] = float(mean);
            double var =
                n > 1 ? std::max(0.0, (sum_sq[3 * p + c] - n * mean * mean) / (n - 1))
                      : 0.0;
            r.variance[3 * p + c] = float(var / n);
        }
    }
    return r;
}

}  // namespace sss

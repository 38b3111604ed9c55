// Integrator "st": path tracing whose collisions deep inside a medium take one learned
// sphere step instead of every scattering event in the largest sphere around them
// (render/sphere_tracing.h, docs/sphere-tracing.md).
#include <chrono>
#include <mutex>

#include "render/integrators/integrator.h"
#include "render/sphere_tracing.h"

namespace sss {

namespace {

// Paths kept in flight per thread: the sphere steps they wait for are sampled together
// (SphereTracing::sample_group), which is what makes a step cheap. Four model calls'
// worth, so that each kind of step (sphere steps, and cut steps, a fifth of them on the
// dielectric bunny) mostly fills its calls: with one call's worth, the cut steps came in
// groups of three or four and cost twice as much (bench/README.md, "cut_steps.py").
constexpr int kPathsInFlight = 4 * SphereTracing::kMaxGroup;

// Work items 0 .. count-1 (camera_ray(item, state) starts one, record(item, sample)
// takes its result), traced kPathsInFlight at a time: each runs until it ends or waits
// for a sphere step; the waiting steps are sampled together, and a path that ends makes
// room for the next item. Every path draws from its own stream, so the results do not
// depend on the grouping (cut steps: up to rounding, CutStepModel::sample_group). Adds
// the time spent sampling steps to step_seconds. Returns false if it saw a cancel (which
// may have cut a path short).
template <class Start, class Record>
bool trace_in_flight(const PathTracer& tracer, const SphereTracing& st, int count,
                     Start&& camera_ray, Record&& record, const std::atomic<bool>& cancel,
                     double& step_seconds) {
    PathState slot[kPathsInFlight];
    for (PathState& ps : slot) ps.cancel = &cancel;
    int item[kPathsInFlight];
    bool busy[kPathsInFlight] = {};
    int next = 0;
    // Advances slot j (taking `step` if given) until its path waits for a step; paths
    // that end are recorded and replaced by the next item.
    auto run = [&](int j, const WorldSphereStep* step) {
        while (tracer.advance(slot[j], step)) {
            record(item[j], slot[j].out);
            step = nullptr;
            if (next >= count || cancel) {  // after a stop, no new paths
                busy[j] = false;
                return;
            }
            item[j] = next++;
            camera_ray(item[j], slot[j]);
        }
    };
    for (int j = 0; j < kPathsInFlight && next < count && !cancel; ++j) {
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
        if (n == 0 || cancel) return !cancel;  // a stop may have cut paths short
        const auto t0 = std::chrono::steady_clock::now();
        st.sample_group(n, req, rng, step);
        step_seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        for (int k = 0; k < n; ++k) run(waiting[k], &step[k]);
    }
}

class SphereTracingIntegrator : public Integrator {
public:
    explicit SphereTracingIntegrator(const IntegratorSetup& setup)
        : setup_(setup),
          st_(setup.scene, setup.options.sphere_threshold, setup.options.sphere_sampler,
              setup.options.models, setup.options.nee, setup.options.step_nee,
              setup.options.cut_models),
          // Where no step can happen, "st" is "pt" path for path: trace it as "pt".
          stepper_(st_.may_step() ? &st_ : nullptr),
          tracer_(setup.scene, setup.options.max_bounces, setup.options.nee, stepper_) {}

    bool render_tile(const TileWork& work, Film& film,
                     const std::atomic<bool>& cancel) override {
        const TileSamples samples(setup_, work);
        if (!stepper_) return trace_paths(samples, tracer_, film, cancel);
        double seconds = 0.0;
        const bool complete = trace_in_flight(
            tracer_, *stepper_, samples.items(),
            [&](int item, PathState& ps) { samples.start(item, tracer_, ps); },
            [&](int item, const PathSample& ps) { samples.record(item, ps, film); },
            cancel, seconds);
        std::lock_guard<std::mutex> lock(step_mutex_);
        step_seconds_ += seconds;
        return complete;
    }

    std::vector<std::string> warnings() const override { return st_.warnings(); }

    double step_seconds() const override {
        std::lock_guard<std::mutex> lock(step_mutex_);
        return step_seconds_;
    }

private:
    IntegratorSetup setup_;
    SphereTracing st_;
    const SphereTracing* stepper_;
    PathTracer tracer_;
    mutable std::mutex step_mutex_;
    double step_seconds_ = 0.0;  // summed over the tiles
};

}  // namespace

IntegratorKind st_integrator_kind() {
    IntegratorKind k;
    k.name = "st";
    k.make = [](const IntegratorSetup& setup) {
        return std::make_unique<SphereTracingIntegrator>(setup);
    };
    return k;
}

}  // namespace sss

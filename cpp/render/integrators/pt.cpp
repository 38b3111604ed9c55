// Integrator "pt": volumetric path tracing with next-event estimation (render/pt.h).
#include "render/integrators/integrator.h"

namespace sss {

namespace {

class PathTracing : public Integrator {
public:
    explicit PathTracing(const IntegratorSetup& setup)
        : setup_(setup),
          tracer_(setup.scene, setup.options.max_bounces, setup.options.nee, nullptr) {}

    bool render_tile(const TileWork& work, Film& film,
                     const std::atomic<bool>& cancel) override {
        return trace_paths(TileSamples(setup_, work), tracer_, film, cancel);
    }

private:
    IntegratorSetup setup_;
    PathTracer tracer_;
};

}  // namespace

IntegratorKind pt_integrator_kind() {
    IntegratorKind k;
    k.name = "pt";
    k.make = [](const IntegratorSetup& setup) {
        return std::make_unique<PathTracing>(setup);
    };
    return k;
}

}  // namespace sss

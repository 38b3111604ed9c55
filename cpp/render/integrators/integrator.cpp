#include "render/integrators/integrator.h"

#include <vector>

#include "core/check.h"
#include "core/rng.h"

namespace sss {

const IntegratorKind& integrator_kind(const std::string& name) {
    static const std::vector<IntegratorKind> kinds = {
#define SSS_INTEGRATOR_ENTRY(name, help) name##_integrator_kind(),
        SSS_INTEGRATORS(SSS_INTEGRATOR_ENTRY)
#undef SSS_INTEGRATOR_ENTRY
    };
    for (const IntegratorKind& k : kinds)
        if (name == k.name) return k;
    fail("integrator '", name, "' is not one of render/integrators/list.h");
}

void TileSamples::start(int item, const PathTracer& tracer, PathState& ps) const {
    int x, y;
    pixel(item, x, y);
    const RenderOptions& opt = setup_.options;
    Rng rng(opt.seed, uint64_t(y) * setup_.scene.desc().camera.width + x,
            uint64_t(work_.s0 + item % m_));
    const float jx = rng.uniform(), jy = rng.uniform();
    const Vec3 d = setup_.camera.direction(x + jx, y + jy);
    tracer.start(ps, setup_.camera.origin() + d * setup_.scene.camera_ray_start(), d,
                 rng);
}

void TileSamples::record(int item, const PathSample& sample, Film& film) const {
    if (setup_.paths.on()) {
        int x, y;
        pixel(item, x, y);
        const Camera& cam = setup_.scene.desc().camera;
        const size_t k = size_t(work_.s0 - setup_.options.first_sample + item % m_);
        setup_.paths.set((k * cam.height + y) * cam.width + x, sample.scatter_events,
                         sample.sphere_steps);
    }
    film.add_sample(item / m_, sample.radiance, sample.scatter_events,
                    sample.sphere_steps);
}

bool trace_paths(const TileSamples& samples, const PathTracer& tracer, Film& film,
                 const std::atomic<bool>& cancel) {
    for (int i = 0; i < samples.items(); ++i) {
        if (cancel) return false;
        PathState ps;
        ps.cancel = &cancel;
        samples.start(i, tracer, ps);
        tracer.advance(ps);
        samples.record(i, ps.out, film);
    }
    return !cancel;  // a stop may have cut the last path short
}

}  // namespace sss

#include "render/sphere_tracing.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/check.h"
#include "media/sphere_walk.h"
#include "nn/scattering_model.h"
#include "shared/sphere_step.h"

namespace sss {

namespace {

// The largest float <= x and the smallest float >= x: a float bound that stays inside a
// double range.
float float_below(double x) {
    float f = float(x);
    return double(f) > x ? std::nextafter(f, -INFINITY) : f;
}
float float_above(double x) {
    float f = float(x);
    return double(f) < x ? std::nextafter(f, INFINITY) : f;
}

}  // namespace

SphereTracing::SphereTracing(const Scene& scene, float threshold, SphereSampler sampler,
                             const std::string& models, bool nee)
    : scene_(scene), threshold_(threshold), sampler_(sampler), nee_(nee) {
    if (!(threshold >= 0.f))
        fail(
            "sphere_threshold must be >= 0 (inf: no sphere steps, the same image as "
            "'pt'), got ",
            threshold);
    if (sampler_ == SphereSampler::Walk || std::isinf(threshold)) return;
    if (models.empty())
        fail(
            "integrator 'st' needs the directory of the sphere-step models "
            "(lengthgen.json, pathgen.json, "
            "eventgen.json): render.models in the scene, --models on the command line, "
            "models= in Python");
    model_ = std::make_unique<ScatteringModel>(ScatteringModel::load(models));

    const Range sigma = model_->sigma_range();
    if (double(threshold_) < sigma.lo)
        fail("sphere_threshold ", threshold_,
             " is below the smallest optical radius the models in ", models,
             " were trained for (sigma from ", sigma.lo, " to ", sigma.hi,
             "); allowed: sphere_threshold >= ", sigma.lo);
    sigma_max_ = float_below(sigma.hi);
    if (const Range* phi = model_->event_gen().training_range("phi")) {
        phi_lo_ = float_above(phi->lo);
        phi_hi_ = float_below(phi->hi);
    }

    // The optical radii a step can have: from the threshold (or the models' lower end) to
    // the upper end; the encodings are monotone, so the two ends cover the interval.
    const float sigma_ends[2] = {
        std::min(std::max(threshold_, float_above(sigma.lo)), sigma_max_), sigma_max_};
    const auto& shapes = scene_.desc().shapes;
    for (size_t i = 0; i < shapes.size(); ++i) {
        const Medium& m = shapes[i].medium;
        if (max_component(m.sigma_t) == 0.f) continue;  // no collisions, no steps
        const bool event = wants_event(int(i));
        auto context = [&] {
            std::ostringstream os;
            os << scene_.desc().source << ": shapes[" << i << "] ('" << shapes[i].name
               << "'): integrator 'st' "
               << "cannot use the sphere-step models in " << models
               << " for this medium: ";
            return os.str();
        };
        for (int c = 0; c < 3; ++c) {
            const float phi = m.albedo[c];
            if (event && (phi < phi_lo_ - kPhiClampTolerance ||
                          phi > phi_hi_ + kPhiClampTolerance))
                fail(context(), "albedo ", phi,
                     " is outside EventGen's training range of phi [", phi_lo_, ", ",
                     phi_hi_,
                     "] (NEE needs EventGen; use nee=False, integrator 'pt', or models "
                     "trained for it)");
            for (float s : sigma_ends) {
                try {
                    model_->check_inputs(s, m.g, event ? event_phi(phi) : 0.5f, event);
                } catch (const Error& e) {
                    fail(context(), e.what(),
                         " (use integrator 'pt', or models trained for this medium)");
                }
            }
        }
    }
}

SphereTracing::~SphereTracing() = default;

bool SphereTracing::wants_event(int shape) const {
    return nee_ && !scene_.desc().lights.empty() &&
           scene_.desc().shapes[shape].boundary.type != BoundaryType::Dielectric;
}

float SphereTracing::event_phi(float phi) const {
    return std::clamp(phi, phi_lo_, phi_hi_);
}

WorldSphereStep SphereTracing::sample(Vec3 p, Vec3 w_in, float radius, float sigma,
                                      float g, float phi, bool with_event,
                                      Rng& rng) const {
    SphereStep s;
    if (sampler_ == SphereSampler::Walk) {
        SphereWalk w = sphere_walk(sigma, g, phi, rng);
        s.N = w.N;
        s.cos_theta = w.cos_theta;
        s.alpha = w.alpha;
        s.beta = w.beta;
        s.X = w.X;
        s.W = w.W;
    } else {
        SSS_CHECK(model_ != nullptr);
        s = model_->sample(sigma, g, event_phi(phi), rng, with_event);
    }
    // Exit frame -> world: z = w_in, a uniform turn psi about it, lengths times the
    // radius.
    const Frame f = sphere_step_frame(w_in, rng.uniform());
    WorldSphereStep out;
    out.N = s.N;
    out.exit_pos = p + f.to_world(sphere_exit_point(s.cos_theta)) * radius;
    out.exit_dir =
        normalize(f.to_world(sphere_exit_direction(s.cos_theta, s.alpha, s.beta)));
    if (with_event) {
        // Both samplers give the first event as exactly X = 0, W = +z (the learned one
        // draws that choice itself; EventGen models the events k >= 2, which lie off the
        // centre).
        out.first_event = s.X == Vec3(0.f) && s.W == Vec3(0.f, 0.f, 1.f);
        out.X = out.first_event ? p : p + f.to_world(s.X) * radius;
        out.W = out.first_event ? w_in : normalize(f.to_world(s.W));
    }
    return out;
}

}  // namespace sss

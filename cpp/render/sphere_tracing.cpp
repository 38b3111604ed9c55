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
                             const std::string& models, bool nee, StepNee step_nee)
    : scene_(scene),
      threshold_(threshold),
      sampler_(sampler),
      nee_(nee),
      step_nee_(step_nee) {
    if (!(threshold >= 0.f))
        fail("sphere_threshold must be a number >= 0 (inf: no sphere steps), got ",
             threshold);
    // A path's first step needs the sphere thick enough in every channel (spectral MIS
    // before it; docs/notation.md, "Colour"), so the smallest extinction decides.
    for (int i = 0; i < scene_.num_shapes(); ++i)
        if (!scene_.desc().shapes[i].is_surface() &&
            min_component(scene_.desc().shapes[i].medium.sigma_t) *
                    scene_.grid(i).max_query() >=
                threshold_)
            may_step_ = true;
    if (!std::isinf(threshold))
        for (const Shape& s : scene_.desc().shapes)
            if (!s.is_surface() && !s.medium.phase.kind().sphere_steps)
                fail(scene_.desc().source, ": shape '", s.name,
                     "': integrator 'st' takes steps trained for Henyey-Greenstein phase "
                     "functions, not phase '",
                     s.medium.phase.kind().name, "' (use integrator 'pt')");
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
        if (shapes[i].is_surface() || max_component(m.sigma_t) == 0.f)
            continue;  // no collisions, no steps
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
                    model_->check_inputs(s, m.phase.x, event ? event_phi(phi) : 0.5f,
                                         event);
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
    if (!nee_ || !scene_.desc().shapes[shape].boundary.passes_shadow_rays()) return false;
    const auto& lights = scene_.desc().lights;
    if (step_nee_ == StepNee::Event) return !lights.empty();
    return std::any_of(lights.begin(), lights.end(),
                       [](const Light& l) { return l.is_delta(); });
}

float SphereTracing::event_phi(float phi) const {
    return std::clamp(phi, phi_lo_, phi_hi_);
}

namespace {

// A step in the exit frame mapped to the world: z = w_in, a uniform turn psi about it
// (one number from rng), lengths times the radius.
WorldSphereStep to_world(const StepRequest& r, const SphereStep& s, Rng& rng) {
    const Frame f = sphere_step_frame(r.w_in, rng.uniform());
    WorldSphereStep out;
    out.N = s.N;
    out.exit_pos = r.p + f.to_world(sphere_exit_point(s.cos_theta)) * r.radius;
    out.exit_dir =
        normalize(f.to_world(sphere_exit_direction(s.cos_theta, s.alpha, s.beta)));
    if (r.with_event) {
        // Both samplers give the first event as exactly X = 0, W = +z (the learned one
        // draws that choice itself; EventGen models the events k >= 2, which lie off the
        // centre).
        out.first_event = s.X == Vec3(0.f) && s.W == Vec3(0.f, 0.f, 1.f);
        out.X = out.first_event ? r.p : r.p + f.to_world(s.X) * r.radius;
        out.W = out.first_event ? r.w_in : normalize(f.to_world(s.W));
    }
    return out;
}

}  // namespace

WorldSphereStep SphereTracing::sample(const StepRequest& r, Rng& rng) const {
    const StepRequest* req = &r;
    Rng* rp = &rng;
    WorldSphereStep out;
    sample_group(1, &req, &rp, &out);
    return out;
}

void SphereTracing::sample_group(int count, const StepRequest* const* requests,
                                 Rng* const* rngs, WorldSphereStep* out) const {
    for (int b = 0; b < count; b += kMaxGroup) {
        const int K = std::min(kMaxGroup, count - b);
        const StepRequest* const* req = requests + b;
        SphereStep s[kMaxGroup];
        if (sampler_ == SphereSampler::Walk) {
            for (int k = 0; k < K; ++k) {
                SphereWalk w =
                    sphere_walk(req[k]->sigma, req[k]->g, req[k]->phi, *rngs[b + k]);
                s[k].N = w.N;
                s[k].cos_theta = w.cos_theta;
                s[k].alpha = w.alpha;
                s[k].beta = w.beta;
                s[k].X = w.X;
                s[k].W = w.W;
            }
        } else {
            SSS_CHECK(model_ != nullptr);
            // One model call for the steps with a representative event and one for those
            // without; each step draws from its own stream, so the split changes nothing.
            for (int event = 0; event < 2; ++event) {
                int idx[kMaxGroup], n = 0;
                float sigma[kMaxGroup], g[kMaxGroup], phi[kMaxGroup];
                Rng rng[kMaxGroup];
                for (int k = 0; k < K; ++k) {
                    if (req[k]->with_event != bool(event)) continue;
                    idx[n] = k;
                    sigma[n] = req[k]->sigma;
                    g[n] = req[k]->g;
                    phi[n] = event_phi(req[k]->phi);
                    rng[n++] = *rngs[b + k];
                }
                if (n == 0) continue;
                SphereStep got[kMaxGroup];
                model_->sample_group(n, sigma, g, phi, rng, bool(event),
                                     DecoderImpl::Simd, got);
                for (int j = 0; j < n; ++j) {
                    s[idx[j]] = got[j];
                    *rngs[b + idx[j]] = rng[j];
                }
            }
        }
        for (int k = 0; k < K; ++k) out[b + k] = to_world(*req[k], s[k], *rngs[b + k]);
    }
}

}  // namespace sss

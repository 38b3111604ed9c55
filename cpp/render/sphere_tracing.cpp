#include "render/sphere_tracing.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/check.h"
#include "geometry/cut_planes.h"
#include "media/sphere_walk.h"
#include "nn/cut_step_model.h"
#include "nn/scattering_model.h"
#include "render/lights/registry.h"
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
                             const std::string& models, bool nee, StepNee step_nee,
                             const std::string& cut_models)
    : scene_(scene),
      threshold_(threshold),
      sampler_(sampler),
      nee_(nee),
      step_nee_(step_nee) {
    if (!(threshold >= 0.f))
        fail("sphere_threshold must be a number >= 0 (inf: no sphere steps), got ",
             threshold);
    const auto& lights = scene_.desc().lights;
    const bool delta_lights = std::any_of(lights.begin(), lights.end(),
                                          [](const Light& l) { return l.is_delta(); });
    for (const Light& l : lights)
        if (l.is_delta() &&
            light_sample(l, Vec3(0.f), 0.5f, 0.5f, scene_.desc().light_floats.data())
                    .dist < kInf)
            points_.push_back(l);
    clearance_.assign(size_t(scene_.num_shapes()), 0.f);
    for (int i = 0; i < scene_.num_shapes(); ++i) {
        const Shape& s = scene_.desc().shapes[i];
        if (s.is_surface()) continue;
        if (step_nee_ == StepNee::Hits && nee_ && delta_lights &&
            scene_.medium_samples_lights(i))
            clearance_[size_t(i)] = kDeltaLightClearance;
    }
    if (!std::isinf(threshold))
        for (const Shape& s : scene_.desc().shapes)
            if (!s.is_surface() && !s.medium.phase.kind().sphere_steps)
                fail(scene_.desc().source, ": shape '", s.name,
                     "': integrator 'st' takes steps trained for Henyey-Greenstein phase "
                     "functions, not phase '",
                     s.medium.phase.kind().name, "' (use integrator 'pt')");
    if (sampler_ != SphereSampler::Walk && !std::isinf(threshold)) load_models(models);
    for (int i = 0; i < scene_.num_shapes(); ++i) may_step_ = may_step_ || can_step(i);
    if (!cut_models.empty()) load_cuts(cut_models);
}

void SphereTracing::load_models(const std::string& models) {
    if (models.empty())
        fail(
            "integrator 'st' needs the directory of the sphere-step models "
            "(lengthgen.json, pathgen.json, "
            "eventgen.json): render.models in the scene, --models on the command line, "
            "models= in Python");
    try {
        model_ = std::make_unique<ScatteringModel>(ScatteringModel::load(models));
    } catch (const Error& e) {  // say which option named the directory
        fail(
            scene_.desc().source,
            ": models (render.models in the scene, --models on the command line, models= "
            "in Python): ",
            e.what());
    }

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
        // The models are never asked where no channel can step (a path steps in one
        // channel, which may be the densest: can_step).
        if (shapes[i].is_surface() ||
            max_component(m.sigma_t) * scene_.grid(int(i)).max_query() <
                threshold_ + clearance_[i])
            continue;
        const bool event = wants_event(int(i));
        // A medium the models were not trained for takes no steps: it renders as with
        // "pt" (exact, only slower), and the render says so (warnings()).
        std::string why;
        for (int c = 0; c < 3 && why.empty(); ++c) {
            const float phi = m.albedo[c];
            if (event && (phi < phi_lo_ - kPhiClampTolerance ||
                          phi > phi_hi_ + kPhiClampTolerance)) {
                std::ostringstream os;
                os << "albedo " << phi << " is outside EventGen's training range of phi ["
                   << phi_lo_ << ", " << phi_hi_
                   << "] (step_nee 'event' needs EventGen; step_nee 'hits' does not)";
                why = os.str();
            }
            for (float s : sigma_ends) {
                if (!why.empty()) break;
                try {
                    model_->check_inputs(s, m.phase.x, event ? event_phi(phi) : 0.5f,
                                         event);
                } catch (const Error& e) {
                    why = e.what();
                }
            }
        }
        if (why.empty()) continue;
        clearance_[i] = kInf;  // no ball is ever clear enough: no step
        std::ostringstream os;
        os << scene_.desc().source << ": shapes[" << i << "] ('" << shapes[i].name
           << "'): integrator 'st' takes no sphere steps in this medium, which renders "
              "as "
           << "with 'pt' (exact, but without st's speed-up): the sphere-step models in "
           << models << " were not trained for it: " << why;
        warnings_.push_back(os.str());
    }
}

SphereTracing::~SphereTracing() = default;

void SphereTracing::load_cuts(const std::string& dir) {
    cut_model_ = std::make_unique<CutStepModel>(CutStepModel::load(dir));
    const Range sigma = cut_model_->range("sigma"), g = cut_model_->range("g"),
                h = cut_model_->range("h"), mu0 = cut_model_->range("mu0");
    if (!(mu0.lo <= -1.0 && mu0.hi >= 1.0))
        fail(dir, ": the cut models were trained for mu0 in [", mu0.lo, ", ", mu0.hi,
             "], not all of [-1, 1]");
    if (!(h.hi >= 1.0))
        fail(dir, ": the cut models were trained for h up to ", h.hi, ", not up to 1");
    cut_sigma_lo_ = float_above(sigma.lo);
    cut_sigma_hi_ = float_below(sigma.hi);
    cut_h_lo_ = float_above(h.lo);
    // The smallest step: kCutMinDepth / kCutRadiusMfp of the radius away from the plane.
    if (!(kCutMinDepth / kCutRadiusMfp >= cut_h_lo_) || !(kCutRadiusMfp >= cut_sigma_lo_))
        fail(dir, ": the cut models' training ranges (sigma from ", sigma.lo, ", h from ",
             h.lo, ") do not cover the cut steps' radius of ", kCutRadiusMfp,
             " mean free paths and planes from ", kCutMinDepth, " mean free paths");
    const auto& shapes = scene_.desc().shapes;
    cut_planes_.resize(shapes.size());
    cut_sigma_min_.assign(shapes.size(), 0.f);
    for (size_t i = 0; i < shapes.size(); ++i) {
        const Shape& s = shapes[i];
        if (s.is_surface() || wants_event(int(i)) || clearance_[i] > 0.f ||
            !s.medium.phase.kind().sphere_steps)
            continue;
        const float sigma_min = min_component(s.medium.sigma_t);
        if (!(sigma_min > 0.f)) continue;
        if (!g.contains(s.medium.phase.x)) {  // sphere steps only, as without cut models
            std::ostringstream os;
            os << scene_.desc().source << ": shapes[" << i << "] ('" << s.name
               << "'): integrator 'st' takes no cut steps in this medium: g = "
               << s.medium.phase.x << " is outside the cut models' training range ["
               << g.lo << ", " << g.hi << "] (models in " << dir << ")";
            warnings_.push_back(os.str());
            continue;
        }
        cut_sigma_min_[i] = sigma_min;
        cut_planes_[i] = std::make_unique<CutPlanes>(
            CutPlanes::build(s.mesh, scene_.grid(int(i)), kCutRadiusMfp / sigma_min, 0,
                             scene_.obstacles(int(i))));
        if (cut_planes_[i]->empty())
            cut_planes_[i].reset();
        else
            may_step_ = true;
    }
}

bool SphereTracing::cut_certificate(int shape, Vec3 p, Vec3* n, float* s) const {
    return cut_planes_[size_t(shape)]->query(p, n, s) &&
           *s * cut_sigma_min_[size_t(shape)] >= kCutMinDepth;
}

void SphereTracing::cut_request(int shape, Vec3 p, Vec3 w_in, Vec3 n, float s,
                                float sigma_t, StepRequest* r) const {
    r->p = p;
    r->w_in = w_in;
    r->radius = std::min(cut_planes_[size_t(shape)]->radius(), cut_sigma_hi_ / sigma_t);
    // sigma >= min(kCutRadiusMfp, the models' upper end) and h >= kCutMinDepth /
    // kCutRadiusMfp, inside the models' ranges (load_cuts checked). A plane beyond the
    // ball cuts nothing: h = 1 is the same region.
    r->sigma = std::min(sigma_t * r->radius, cut_sigma_hi_);
    r->g = scene_.desc().shapes[size_t(shape)].medium.phase.x;
    r->cut = true;
    r->cut_n = n;
    r->cut_h = std::min(s / r->radius, 1.f);
    r->cut_mu0 = std::clamp(dot(w_in, n), -1.f, 1.f);
    r->with_event = false;
}

namespace {

// A cut step in the walk's frame mapped to the world: z = the plane's normal n, x the
// part of w_in across n (any direction across n if none), lengths times the radius.
WorldSphereStep cut_to_world(const StepRequest& r, const CutStep& c) {
    const Vec3 n = r.cut_n;
    Vec3 x = r.w_in - n * r.cut_mu0;
    const float lx = length(x);
    x = lx > 1e-6f ? x / lx : frame_from_z(n).s;
    const Vec3 y = cross(n, x);
    auto to_world = [&](Vec3 v) { return x * v.x + y * v.y + n * v.z; };
    WorldSphereStep out;
    out.N = c.N;
    out.exit_pos = r.p + to_world(c.exit_pos) * r.radius;
    out.exit_dir = normalize(to_world(c.exit_dir));
    out.X = r.p;
    out.W = r.w_in;
    out.first_event = true;
    return out;
}

}  // namespace

bool SphereTracing::can_step(int shape) const {
    // A path's first step comes where it goes on in one channel (spectral MIS before it:
    // docs/notation.md, "Colour"), so spectral_switch_extinction decides (for a grey
    // medium, its extinction).
    const Shape& s = scene_.desc().shapes[size_t(shape)];
    return !s.is_surface() && spectral_switch_extinction(s.medium.sigma_t) *
                                      scene_.grid(shape).max_query() >=
                                  threshold_ + clearance_[size_t(shape)];
}

bool SphereTracing::wants_event(int shape) const {
    return step_nee_ == StepNee::Event && nee_ && !scene_.desc().lights.empty() &&
           scene_.medium_samples_lights(shape);
}

float SphereTracing::cleared_radius(Vec3 p, float r, float sigma, float clearance) const {
    // Too close to the boundary for a step whatever the lights: no need to look at them
    // (and no ball, even where r - clearance / sigma would round up to the threshold).
    if (sigma * r < threshold_ + clearance) return -1.f;
    float light_dist = kInf;
    for (const LightData& l : points_)
        light_dist = std::min(
            light_dist,
            light_sample(l, p, 0.5f, 0.5f, scene_.desc().light_floats.data()).dist);
    return cleared_step_radius(r, light_dist, clearance, sigma);
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
    // The requests by kind: cut steps, then sphere steps without and with a
    // representative event, each kind in model calls of up to kMaxGroup cut steps or
    // ScatteringModel::kMaxGroup sphere steps (the decoders run on 16 of them at once, so
    // full calls are cheapest per step; and the sphere steps the tilt draws again fill
    // the lanes of a call's later evaluations). Each step draws from its own stream, so
    // the grouping changes nothing (up to rounding for cut steps,
    // CutStepModel::sample_group). next(kind, from, idx) gathers the next call's requests
    // of a kind at or after `from` into idx and returns their count.
    auto kind_of = [&](int k) {
        return requests[k]->cut ? 0 : requests[k]->with_event ? 2 : 1;
    };
    auto next = [&](int kind, int& from, int* idx) {
        const int most = kind == 0 ? kMaxGroup : ScatteringModel::kMaxGroup;
        int n = 0;
        for (; from < count && n < most; ++from)
            if (kind_of(from) == kind) idx[n++] = from;
        return n;
    };
    int idx[ScatteringModel::kMaxGroup];
    for (int from = 0, n; (n = next(0, from, idx)) > 0;) {
        float sigma[kMaxGroup], g[kMaxGroup], h[kMaxGroup], mu0[kMaxGroup];
        Rng rng[kMaxGroup];
        for (int j = 0; j < n; ++j) {
            const StepRequest& r = *requests[idx[j]];
            sigma[j] = r.sigma;
            g[j] = r.g;
            h[j] = r.cut_h;
            mu0[j] = r.cut_mu0;
            rng[j] = *rngs[idx[j]];
        }
        CutStep c[kMaxGroup];
        if (sampler_ == SphereSampler::Walk) {  // exact walks for the networks
            for (int j = 0; j < n; ++j) {
                const CutSphereWalk w =
                    cut_sphere_walk(sigma[j], g[j], h[j], mu0[j], 1.f, rng[j]);
                c[j].N = w.N;
                c[j].exit_pos = w.exit_pos;
                c[j].exit_dir = w.exit_dir;
            }
        } else {
            SSS_CHECK(cut_model_ != nullptr);
            cut_model_->sample_group(n, sigma, g, h, mu0, rng, c);
        }
        for (int j = 0; j < n; ++j) {
            *rngs[idx[j]] = rng[j];
            out[idx[j]] = cut_to_world(*requests[idx[j]], c[j]);
        }
    }
    for (int with_event = 0; with_event < 2; ++with_event) {
        for (int from = 0, n; (n = next(1 + with_event, from, idx)) > 0;) {
            SphereStep s[ScatteringModel::kMaxGroup];
            if (sampler_ == SphereSampler::Walk) {
                for (int j = 0; j < n; ++j) {
                    const StepRequest& r = *requests[idx[j]];
                    SphereWalk w = sphere_walk(r.sigma, r.g, r.phi, *rngs[idx[j]]);
                    s[j].N = w.N;
                    s[j].cos_theta = w.cos_theta;
                    s[j].alpha = w.alpha;
                    s[j].beta = w.beta;
                    s[j].X = w.X;
                    s[j].W = w.W;
                }
            } else {
                SSS_CHECK(model_ != nullptr);
                constexpr int kMost = ScatteringModel::kMaxGroup;
                float sigma[kMost], g[kMost], phi[kMost];
                Rng rng[kMost];
                for (int j = 0; j < n; ++j) {
                    const StepRequest& r = *requests[idx[j]];
                    sigma[j] = r.sigma;
                    g[j] = r.g;
                    phi[j] = event_phi(r.phi);
                    rng[j] = *rngs[idx[j]];
                }
                model_->sample_group(n, sigma, g, phi, rng, bool(with_event),
                                     DecoderImpl::Simd, s);
                for (int j = 0; j < n; ++j) *rngs[idx[j]] = rng[j];
            }
            for (int j = 0; j < n; ++j)
                out[idx[j]] = to_world(*requests[idx[j]], s[j], *rngs[idx[j]]);
        }
    }
}

}  // namespace sss

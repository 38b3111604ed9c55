#include "render/pt.h"

#include <cmath>
#include <limits>

#include "core/check.h"
#include "render/sphere_tracing.h"
#include "shared/fresnel.h"
#include "shared/hg.h"
#include "shared/path.h"
#include "shared/ray_offset.h"
#include "shared/sampling.h"
#include "shared/sphere_step.h"

namespace sss {

namespace {

float extinction(const Medium& m, int channel) {
    return channel < 0 ? m.sigma_t.x : m.sigma_t[channel];
}

// The origin of a ray leaving the surface point of `hit` in direction w: past the hit
// point's rounding-error bound, on w's side (shared/ray_offset.h; no absolute epsilon).
Vec3 leave(const Hit& hit, const Vec3& w) {
    return offset_ray_origin(hit.p, hit.p_error, hit.normal, w);
}

bool survives_roulette(Vec3& beta, float beta_start, Rng& rng) {
    return survives_roulette(beta, beta_start, rng.state());  // shared/path.h
}

// Sphere tracing a shadow ray from a scattering event through its medium's distance grid
// (query(t): the bound at the ray's point t along it): each bound is a ball free of the
// surface, so the ray stays inside the medium for at least the t reached, where the
// first bound r (at t = 0) is known. Returns shadow_keep_again for exp(-sigma t), t no
// further than the light at dist.
template <class Query>
float shadow_march_keep(const Query& query, float r, float dist, float sigma,
                        float kept) {
    float t = r;
    for (int i = 1; i < kShadowMarchQueries && t < dist && sigma * t < kShadowMarchDepth;
         ++i) {
        const float step = query(t);
        if (!(step > 0.f)) break;
        t += step;
    }
    return shadow_keep_again(std::exp(-sigma * std::min(t, dist)), kept);
}

}  // namespace

PathTracer::PathTracer(const Scene& scene, int max_bounces, bool nee,
                       const SphereTracing* sphere_tracing)
    : scene_(scene), max_bounces_(max_bounces), nee_(nee), st_(sphere_tracing) {
    const auto& lights = scene_.desc().lights;
    for (size_t i = 0; i < lights.size(); ++i)
        if (lights[i].is_delta()) delta_lights_.push_back(int(i));
    near_points_.resize(size_t(scene_.num_shapes()));
    for (int s = 0; s < scene_.num_shapes(); ++s) {
        const Shape& shape = scene_.desc().shapes[size_t(s)];
        if (shape.is_surface()) continue;
        const Bounds3 bounds = shape.mesh.bounds();
        for (int i : delta_lights_)
            if (lights[size_t(i)].kind().position_key &&
                bounds.contains(lights[size_t(i)].a))
                near_points_[size_t(s)].push_back(i);
    }
}

Vec3 PathTracer::transmittance(const Vec3& p, const Vec3& w, float dist, int shape,
                               EmitterHit* emitter, int light_in) const {
    const auto& shapes = scene_.desc().shapes;
    Crossing hits[kMaxShadowCrossings];
    const int n = scene_.tracer().crossings(p, w, dist, hits, kMaxShadowCrossings);
    if (n < 0) return Vec3(0.f);
    Vec3 tr(1.f);
    float t_prev = 0.f;
    for (int i = 0; i < n; ++i) {
        const Crossing& h = hits[i];
        if (shape >= 0) tr *= beer(shapes[shape].medium.sigma_t, h.t - t_prev);
        if (int(h.mesh) >= scene_.num_shapes()) {  // an emitter's quad
            if (!emitter) return Vec3(0.f);
            emitter->light = scene_.area_light_of_mesh(h.mesh);
            emitter->t = h.t;
            emitter->normal = h.normal;
            return tr;
        }
        // A surface at the light itself (a lamp standing on a floor) does not block it:
        // whether the ray meets it there is a matter of rounding (area lights end their
        // rays as short of the quad: render/lights/area.h).
        if (shapes[h.mesh].is_surface() && h.t >= kShadowRayEnd * dist) return tr;
        // So does the face of the medium the light lies in, met leaving it at the light:
        // a light on the face is inside (Scene::light_medium), and rounding decides
        // whether the ray meets the face first (a lamp on a wax block's top).
        if (int(h.mesh) == light_in && shape == light_in && h.t >= kShadowRayEnd * dist) {
            t_prev = h.t;
            break;
        }
        if (shapes[h.mesh].is_surface() || !shapes[h.mesh].boundary.passes_shadow_rays())
            return Vec3(0.f);
        shape = dot(w, h.normal) < 0.f ? int(h.mesh) : -1;
        t_prev = h.t;
    }
    if (shape >= 0) tr *= beer(shapes[shape].medium.sigma_t, dist - t_prev);
    if (emitter && !(dist < kInf)) {  // out of the scene: the environment, if any
        emitter->light = scene_.environment();
        emitter->t = kInf;
    }
    return tr;
}

bool PathTracer::face_at(const Vec3& o, const Vec3& d, const Hit& surface, int shape,
                         Hit* face) const {
    return scene_.touches_surfaces(shape) && scene_.other_at(o, d, surface, face) &&
           int(face->mesh) == shape && scene_.touches_surface(shape, face->prim) &&
           dot(d, face->normal) > 0.f;
}

namespace {

// A scattering event in a medium, for sample_light: the phase function is its own pdf,
// and shadow rays start at the event.
struct MediumScatter {
    const Phase& phase;
    Vec3 p, d;  // where, and the direction the photon arrived along
    int shape;  // the medium
    // For the shadow-ray roulette: the medium's grid and the distance bound r at p, the
    // extinction the bounds use, and the probability the roulette on exp(-sigma r)
    // already kept this vertex's NEE with.
    const DistanceGrid& grid;
    float r, sigma, kept;
    SurfaceEval eval(const Vec3& w, bool /*delta_light*/) const {
        SurfaceEval e;
        e.pdf = phase_eval(phase, dot(d, w));
        e.f = Vec3(e.pdf);
        return e;
    }
    Vec3 origin(const Vec3&) const { return p; }
    int shape_along(const Vec3&) const { return shape; }
    const Phase* phase_function() const { return &phase; }
    // The probability to trace the shadow ray along w to a light dist away: the ray's
    // transmittance is at most exp(-sigma t) for the distance t it provably runs inside
    // the medium, which sphere tracing the grid finds (docs/notation.md, "Shadow-ray
    // Russian roulette"); kept again with that bound / kShadowRoulette over `kept`.
    float shadow_keep(const Vec3& w, float dist) const {
        return shadow_march_keep([&](float t) { return grid.query(p + w * t); }, r, dist,
                                 sigma, kept);
    }
};

// A reflection on an opaque surface, for sample_light: the BSDF times the cosine, and
// shadow rays start off the surface on their side.
struct SurfaceScatter {
    const Surface& surface;
    const Hit& hit;
    Vec3 d;
    int shape;  // the medium the surface touches there, -1: vacuum
    SurfaceEval eval(const Vec3& w, bool /*delta_light*/) const {
        return surface_eval(surface, -d, w, hit.normal);
    }
    Vec3 origin(const Vec3& w) const { return leave(hit, w); }
    int shape_along(const Vec3&) const { return shape; }
    const Phase* phase_function() const { return nullptr; }
    float shadow_keep(const Vec3&, float) const { return 1.f; }
};

// A vertex on a rough (or regularized) boundary, for sample_light: its BSDF (reflection
// or transmission), and shadow rays start off the surface on their side, inside the shape
// or outside. `covered`: an opaque surface lies on the face here (across_gap), and no
// light reaches the vertex from outside; a shadow ray started off the face on that side
// may start past the surface (a cube resting on a floor was lit by a lamp under the
// floor).
struct BoundaryScatter {
    const Boundary& boundary;
    const Hit& hit;
    Vec3 d;
    bool covered;
    SurfaceEval eval(const Vec3& w, bool delta_light) const {
        if (covered && dot(w, hit.normal) >= 0.f) return SurfaceEval{Vec3(0.f), 0.f};
        const BoundaryEval b = boundary_eval(boundary, d, w, hit.normal, delta_light);
        return SurfaceEval{Vec3(b.f), b.pdf};
    }
    Vec3 origin(const Vec3& w) const { return leave(hit, w); }
    int shape_along(const Vec3& w) const {
        return dot(w, hit.normal) < 0.f ? int(hit.mesh) : -1;
    }
    const Phase* phase_function() const { return nullptr; }
    float shadow_keep(const Vec3&, float) const { return 1.f; }
};

}  // namespace

Vec3 PathTracer::direct_light(const Vec3& p, float r, const Vec3& d, int shape,
                              int channel, Rng& rng, bool mis) const {
    const Shape& s = scene_.desc().shapes[shape];
    // A straight shadow ray never leaves a dielectric boundary (docs/notation.md,
    // "Next-event estimation"); inside one only a point light there is reached (the
    // others' shadow rays end at the boundary: transmittance).
    if (!scene_.medium_samples_lights(shape)) return Vec3(0.f);
    // Every shadow ray first travels at least r through this medium.
    float sigma_min =
        channel < 0 ? min_component(s.medium.sigma_t) : s.medium.sigma_t[channel];
    const DistanceGrid& grid = scene_.grid(shape);
    if (r < 0.f) r = grid.query(p);
    // ... or as far as a point light inside the medium, if nearer (a candle in wax: with
    // r alone, its light came through almost never, with a huge weight).
    float reach = r;
    for (int i : near_points_[size_t(shape)])
        reach = std::min(reach, light_sample(scene_.desc().lights[size_t(i)], p, 0.5f,
                                             0.5f, scene_.light_floats())
                                    .dist);
    const float kept = shadow_keep_probability(std::exp(-sigma_min * reach));
    float shadow_weight = 1.f;
    if (kept < 1.f) {
        shadow_weight = roulette_weight(kept, rng.uniform());
        if (shadow_weight == 0.f) return Vec3(0.f);
    }
    return sample_light(
               p, MediumScatter{s.medium.phase, p, d, shape, grid, r, sigma_min, kept},
               rng, mis) *
           shadow_weight;
}

template <class Scatter>
Vec3 PathTracer::sample_light(const Vec3& p, const Scatter& scatter, Rng& rng, bool mis,
                              bool delta_only) const {
    // One light per vertex, chosen uniformly: the estimate is weighted by n_lights, and
    // the light-sampling pdfs in the MIS weights carry the selection probability 1 /
    // n_lights (as on emission hits in run()).
    const auto& lights = scene_.desc().lights;
    const size_t count = delta_only ? delta_lights_.size() : lights.size();
    if (count == 0) return Vec3(0.f);
    const float n_lights = float(count);
    size_t i = std::min(count - 1, size_t(rng.uniform() * n_lights));
    if (delta_only) i = size_t(delta_lights_[i]);
    const Light& l = lights[i];
    const float u1 = rng.uniform(), u2 = rng.uniform();
    LightSample ls =
        light_sample(l, p, u1, u2, scene_.light_floats());  // render/lights/registry.h
    ls.L *= scene_.light_scale(int(i));  // a point light inside a dielectric medium
    Vec3 sum(0.f);
    const SurfaceEval f = scatter.eval(ls.w, l.is_delta());
    // A second shadow-ray roulette, on the bound along the light's direction.
    float shadow_weight = 1.f;
    if (!is_black(ls.L) && !is_black(f.f)) {
        const float keep = scatter.shadow_keep(ls.w, ls.dist);
        if (keep < 1.f) shadow_weight = roulette_weight(keep, rng.uniform());
    }
    if (shadow_weight > 0.f && !is_black(ls.L) && !is_black(f.f)) {
        const Vec3 tr = shadow_weight * transmittance(scatter.origin(ls.w), ls.w, ls.dist,
                                                      scatter.shape_along(ls.w), nullptr,
                                                      scene_.light_medium(int(i)));
        if (ls.pdf == 0.f) {
            sum += ls.L * tr * f.f;  // a delta light
        } else {
            // With mis, the partner is the path's own sampled continuation (which sees
            // the light selection too); without, the phase-sampled shadow ray below.
            const float mis_w = power_heuristic(mis ? ls.pdf / n_lights : ls.pdf, f.pdf);
            sum += ls.L * tr * f.f * (mis_w / ls.pdf);
        }
    }
    if (!mis && !l.is_delta()) {
        // The second strategy (media only: a sphere step's events): a phase-sampled
        // shadow ray that meets this light (phase / pdf = 1).
        const Phase* phase = scatter.phase_function();
        SSS_CHECK(phase != nullptr);
        const Vec3 wp = phase_sample(*phase, scatter.d, rng.uniform(), rng.uniform());
        EmitterHit e;
        const Vec3 trp = transmittance(p, wp, kInf, scatter.shape_along(wp), &e);
        if (e.light == int(i)) {
            const LightEval le =
                light_eval(l, p, wp, e.t, e.normal, scene_.light_floats());
            sum += le.L * trp *
                   power_heuristic(phase_eval(*phase, dot(scatter.d, wp)), le.pdf);
        }
    }
    return sum * n_lights;
}

void PathTracer::start(PathState& ps, const Vec3& o, const Vec3& d,
                       const Rng& rng) const {
    const std::atomic<bool>* cancel = ps.cancel;  // the slot's, kept for its next paths
    ps = PathState();
    ps.cancel = cancel;
    ps.rng = rng;
    ps.o = o;
    ps.d = d;
    // RGB media with differing channels (docs/notation.md, "Colour"): a hero channel,
    // chosen uniformly, samples the flights, and the path carries all three channels with
    // spectral MIS ("st" until its first sphere step). Grey media: all three channels at
    // once.
    if (!scene_.grey_media()) {
        ps.channel = std::min(2, int(ps.rng.uniform() * 3.f));
        ps.spectral = true;
    }
    ps.beta_start = max_component(ps.beta);
}

bool PathTracer::advance(PathState& ps, const WorldSphereStep* step) const {
    return st_ ? run<true>(ps, step) : run<false>(ps, step);
}

PathSample PathTracer::trace(const Vec3& o, const Vec3& d, Rng& rng) const {
    PathState ps;
    start(ps, o, d, rng);
    if (!st_) {
        run<false>(ps, nullptr);
    } else {
        for (bool done = run<true>(ps, nullptr); !done;) {
            const WorldSphereStep step = st_->sample(ps.step, ps.rng);
            done = run<true>(ps, &step);
        }
    }
    rng = ps.rng;
    return ps.out;
}

bool PathTracer::take_step(PathState& ps, const WorldSphereStep& step) const {
    const Shape& s = scene_.desc().shapes[ps.shape];
    const Vec3 albedo = s.medium.albedo;
    const StepRequest& req = ps.step;
    Vec3 survival, nee_weight = req.nee_weight;
    for (int c = 0; c < 3; ++c) {
        survival[c] = float(survival_power(albedo[c], step.N));
        if (req.with_event) nee_weight[c] *= float(event_weight_sum(albedo[c], step.N));
    }
    // StepNee::Hits: the step's events sample no light; their light reaches them through
    // the exit flight, whose hit counts with weight 1 (specular below), as in pt without
    // NEE. Point and directional lights, which no flight hits, are kept away from them
    // instead (SphereTracing::clearance).
    // StepNee::Event: NEE from the representative event, weighted by Lambda = sum_j
    // phi^j, with the throughput on entering the sphere. MIS needs the same vertex on
    // both sides: the first event (at o) is known, so it keeps pt's MIS, and its
    // phase-sampled light hit (only possible for N = 1) keeps its weight. For N >= 2 the
    // last event is unknown: its light hit gets weight 0 (phase_pdf = 0 below) and the
    // events k >= 2 use light sampling alone.
    const bool hits = st_->step_nee() == StepNee::Hits;
    if (req.with_event && !is_black(nee_weight))
        ps.L += ps.beta * nee_weight *
                direct_light(step.X, -1.f, step.W, ps.shape, ps.channel, ps.rng,
                             step.first_event);
    ps.beta *= survival;
    bool alive = !is_black(ps.beta);
    if (alive) {
        ps.phase_pdf =
            step.N == 1 ? phase_eval(s.medium.phase, dot(ps.d, step.exit_dir)) : 0.f;
        ps.scatter_pos = ps.o;
        ps.o = step.exit_pos;
        ps.d = step.exit_dir;
        ps.specular = hits;
        ps.r_at_o = -1.f;
        alive = survives_roulette(ps.beta, ps.beta_start, ps.rng);
    }
    if (!alive) ps.out.radiance = ps.L;
    return alive;
}

void PathTracer::request_step(PathState& ps, float r) const {
    const Medium& m = scene_.desc().shapes[ps.shape].medium;
    const float sigma_t = extinction(m, ps.channel);
    SSS_CHECK(!ps.spectral);
    ++ps.out.sphere_steps;
    StepRequest& req = ps.step;
    req.cut = false;
    req.p = ps.o;
    req.w_in = ps.d;
    req.sigma = std::min(sigma_t * r, st_->sigma_max());
    req.radius = std::min(r, req.sigma / sigma_t);
    req.g = m.phase.x;  // Henyey-Greenstein's g (PhaseKind::sphere_steps)
    req.with_event = st_->wants_event(ps.shape);
    // The representative event is drawn for one albedo: the carried channel's, or, for
    // RGB throughput with a chromatic albedo, a channel picked uniformly whose light
    // connection then counts 3 times in that channel only.
    req.phi = m.albedo[ps.channel < 0 ? 0 : ps.channel];
    req.nee_weight = Vec3(1.f);
    if (req.with_event && ps.channel < 0 &&
        !(m.albedo.x == m.albedo.y && m.albedo.x == m.albedo.z)) {
        const int c = std::min(2, int(ps.rng.uniform() * 3.f));
        req.phi = m.albedo[c];
        req.nee_weight = Vec3(0.f);
        req.nee_weight[c] = 3.f;
    }
}

void PathTracer::request_cut_step(PathState& ps, Vec3 n, float s) const {
    const Medium& m = scene_.desc().shapes[ps.shape].medium;
    SSS_CHECK(!ps.spectral);
    ++ps.out.sphere_steps;
    StepRequest& req = ps.step;
    st_->cut_request(ps.shape, ps.o, ps.d, n, s, extinction(m, ps.channel), &req);
    req.phi = m.albedo[ps.channel < 0 ? 0 : ps.channel];
    req.nee_weight = Vec3(1.f);
}

template <bool kSphereTracing>
bool PathTracer::run(PathState& ps, const WorldSphereStep* step) const {
    if constexpr (kSphereTracing) {
        // The sphere step this path waited for (requested below).
        if (step && !take_step(ps, *step)) return true;
    }
    const SceneDesc& desc = scene_.desc();
    // The path's state in locals for the loop (written back when it waits for a step).
    Rng rng = ps.rng;
    Vec3 o = ps.o, d = ps.d, L = ps.L, beta = ps.beta, ratio = ps.ratio;
    float beta_start = ps.beta_start;
    int channel = ps.channel;
    bool spectral = ps.spectral;
    int shape = ps.shape;
    bool specular = ps.specular;
    float phase_pdf = ps.phase_pdf;
    Vec3 scatter_pos = ps.scatter_pos;
    float r_at_o = ps.r_at_o;
    bool r_shrunk = false;  // r_at_o is a shrunk ball's radius, not the grid's bound
    // st: the cell of the last grid query (in shape query_shape) and the largest bound
    // the grid gives in it (DistanceGrid::query).
    int query_shape = -1;
    int64_t query_cell = -1;
    float query_cell_bound = 0.f;
    PathSample out = ps.out;
    auto suspend = [&]() {
        ps.rng = rng;
        ps.o = o, ps.d = d, ps.L = L, ps.beta = beta, ps.ratio = ratio;
        ps.beta_start = beta_start;
        ps.channel = channel;
        ps.spectral = spectral;
        ps.shape = shape;
        ps.specular = specular;
        ps.phase_pdf = phase_pdf;
        ps.scatter_pos = scatter_pos;
        ps.r_at_o = r_at_o;
        ps.out = out;
    };
    auto finish = [&]() {
        ps.rng = rng;
        out.radiance = L;
        ps.out = out;
        return true;
    };
    // What a vertex's light contributes is weighted by `weight()`: the throughput, over
    // the channels' mean relative pdf with spectral MIS (the balance heuristic over the
    // hero channel's choice; docs/notation.md, "Colour").
    auto weight = [&]() {
        return spectral ? beta * (3.f / (ratio.x + ratio.y + ratio.z)) : beta;
    };
    // Roulette on that weight: the start value scales by the same mean.
    auto roulette = [&]() {
        const float start =
            spectral ? beta_start * (ratio.x + ratio.y + ratio.z) / 3.f : beta_start;
        return survives_roulette(beta, start, rng);
    };
    // NEE picks one light uniformly: the light-sampling pdfs in MIS weights carry 1/n.
    const float light_select_pdf =
        desc.lights.empty() ? 0.f : 1.f / float(desc.lights.size());
    // An opaque surface at `hit`, met in vacuum or (where a surface touches a medium)
    // inside medium `shape`: light sampling, then a reflected direction (BSDF sampling,
    // whose pdf an emitter hit next shares MIS with); false when the path ends there.
    // It counts as a scattering event.
    auto reflect = [&](const Hit& hit, const Surface& surface) {
        // The event past max_bounces ends the path without happening (not counted).
        if (max_bounces_ >= 0 && int(out.scatter_events) >= max_bounces_) return false;
        ++out.scatter_events;
        if (nee_ && !desc.lights.empty())
            L += weight() *
                 sample_light(hit.p, SurfaceScatter{surface, hit, d, shape}, rng);
        const float u1 = rng.uniform(), u2 = rng.uniform();
        const SurfaceSample ss = surface_sample(surface, -d, hit.normal, u1, u2);
        beta *= ss.weight;
        if (!(ss.pdf > 0.f) || is_black(beta)) return false;
        phase_pdf = ss.pdf;
        scatter_pos = hit.p;
        specular = false;
        d = ss.wo;
        o = leave(hit, d);
        r_at_o = -1.f;
        return roulette();
    };
    // The photon meets the boundary of the shape of `hit`, from outside or from inside:
    // on a rough interface the meeting point is a path vertex that samples lights first
    // (on a regularized smooth one, the point and directional lights);
    // then the boundary reflects or transmits it. False when the path ends there.
    // `covered`: an opaque surface lies on the face there (across_gap).
    auto cross = [&](const Hit& hit, const Boundary& boundary, bool covered = false) {
        if (nee_ && !desc.lights.empty() && boundary.samples_lights())
            L +=
                weight() * sample_light(hit.p, BoundaryScatter{boundary, hit, d, covered},
                                        rng, true, boundary.samples_delta_lights_only());
        const BoundaryEvent b = boundary_cross(boundary, d, hit.normal, rng.state());
        beta *= b.weight;
        if (is_black(beta)) return false;
        if (b.pdf > 0.f) {  // a sampled lobe: the next emitter hit shares MIS with it
            phase_pdf = b.pdf;
            scatter_pos = hit.p;
            specular = false;
        } else {
            specular = specular || b.specular;
        }
        d = b.d;
        o = leave(hit, d);
        if (b.crossed) shape = shape < 0 ? int(hit.mesh) : -1;
        r_at_o = shape >= 0 ? 0.f : -1.f;  // on the surface: the grid could only say so
        return true;
    };

    // The photon meets, from inside, the face of `hit` where an opaque surface lies on it
    // (at `on`: a cube resting on a floor). It meets it as across a gap too thin to see,
    // so that the image is the one of the medium lifted off the surface by any small gap:
    // the face reflects or transmits it; out in the gap, it reflects off the surface and
    // meets the face again, until it is back inside, leaves along the gap, or the path
    // ends (false). Behind an index-matched face that is the surface as seen from inside,
    // which its shadow rays, starting in the medium, also see right: run takes that.
    auto across_gap = [&](const Hit& face, const Hit& on, const Boundary& boundary) {
        if (!cross(face, boundary, true)) return false;
        while (shape < 0) {
            if (!reflect(on, desc.shapes[on.mesh].surface)) return false;
            if (!(dot(d, face.normal) < 0.f)) return true;  // o: off the surface
            if (!cross(face, boundary, true)) return false;
        }
        return true;
    };

    // A stop (Ctrl-C) ends even a path of 1e9 flights within a second (65536 flights are
    // a few ms): in a medium, or between the walls of a white room. The render then drops
    // the tile it was part of, so the cut path counts nowhere.
    uint32_t flights = 0;
    for (;;) {
        if ((++flights & 0xFFFFu) == 0 && ps.cancel &&
            ps.cancel->load(std::memory_order_relaxed))
            break;
        if (shape < 0) {
            // Vacuum: fly to the next surface.
            Hit hit;
            if (!scene_.tracer().intersect(o, d, 0.f, kInf, &hit)) {
                if (const int env = scene_.environment(); env >= 0) {
                    const LightEval e = light_eval(desc.lights[env], scatter_pos, d, kInf,
                                                   Vec3(0.f), scene_.light_floats());
                    const float w =
                        specular || !nee_
                            ? 1.f
                            : power_heuristic(phase_pdf, e.pdf * light_select_pdf);
                    L += weight() * e.L * w;
                }
                break;
            }
            const Vec3& p = hit.p;
            if (const int light = scene_.area_light_of_mesh(hit.mesh); light >= 0) {
                // The light-sampling pdf is that of NEE at the last scattering event, so
                // distances count from there, across any index-matched boundaries.
                const LightEval e = light_eval(desc.lights[light], scatter_pos, d,
                                               length(p - scatter_pos), hit.normal,
                                               scene_.light_floats());
                const float w =
                    specular || !nee_
                        ? 1.f
                        : power_heuristic(phase_pdf, e.pdf * light_select_pdf);
                L += weight() * e.L * w;
                break;  // emitters absorb
            }
            const Shape& s = desc.shapes[hit.mesh];
            if (s.is_surface()) {
                if (!reflect(hit, s.surface)) break;
                continue;
            }
            if (dot(d, hit.normal) >= 0.f) {
                // Leaving a shape the path never entered (a grazing hit on a silhouette
                // edge): the crossing says it is outside now, as it was.
                o = leave(hit, d);
                continue;
            }
            if (Hit on; scene_.surface_at(o, d, hit, &on)) {
                if (!reflect(on, desc.shapes[on.mesh].surface)) break;
                continue;
            }
            if (!cross(hit, s.boundary)) break;
            continue;
        }

        // Inside a medium: sample a free flight; the distance grid tells when the
        // boundary cannot be reached, which saves the boundary ray.
        const Shape& s = desc.shapes[shape];
        float t = sample_exponential(rng.uniform(), extinction(s.medium, channel));
        Hit hit;
        bool at_boundary = false;
        const DistanceGrid& grid = scene_.grid(shape);
        // st keeps the cell of its last query and the grid's largest bound in it.
        auto query = [&](const Vec3& p) {
            if constexpr (kSphereTracing) {
                query_shape = shape;
                return grid.query(p, &query_cell, &query_cell_bound);
            } else {
                return grid.query(p);
            }
        };
        float r_o = r_at_o >= 0.f ? r_at_o : query(o);
        // A shrunk ball (below) that does not hold the flight: the grid may hold more.
        if (r_shrunk && !(t < r_o)) r_o = std::max(r_o, query(o));
        r_shrunk = false;
        r_at_o = -1.f;
        // The balls of radius r_o around o and r_end around the flight's end hold no
        // boundary: when they cover the flight (t < r_o + r_end), it cannot reach the
        // boundary either. r_end is kept for the collision there.
        const Vec3 end = o + d * t;
        float r_end = -1.f;
        bool ray_cast = false;
        if (!(t < r_o)) {
            if (t < kInf) r_end = query(end);
            ray_cast = !(t < r_o + r_end);
            if (ray_cast) at_boundary = scene_.tracer().intersect(o, d, 0.f, t, &hit);
        }
        if (!at_boundary &&
            (!(t < kInf) || (ray_cast && !grid.empty() && grid.cell_of(end) < 0))) {
            // A numerical leak out of the mesh: no boundary ahead of an unbounded flight,
            // or one whose ray met no boundary but ends outside the grid, which holds the
            // mesh with a cell to spare. (A collision that lands on the surface, to the
            // float, starts a flight whose ray cannot see the crossing at its origin:
            // such a photon walks on outside until it meets the surface again or leaves
            // the grid; with albedo 1 it walked for ever.) It goes on along d from where
            // it is, as from the crossing. render.glsl does the same.
            if (t < kInf) o = end;
            shape = -1;
            continue;
        }
        if (spectral) {
            const Vec3 f = hero_flight_ratio(s.medium.sigma_t, channel,
                                             at_boundary ? hit.t : t, !at_boundary);
            ratio *= f;
            beta *= f;
        }

        if (!at_boundary) {
            o = end;
            // A flight inside the ball of radius r_o around its start ends inside the
            // ball of radius r_o - t around its end (the distance is 1-Lipschitz; the
            // margin covers rounding in o + d t, as the grid's guard does in a query).
            // That bound costs no query; the next flight asks the grid only if it reaches
            // past it. st takes it only where the grid's bound cannot allow a step
            // anywhere in o's cell: the shrunk ball, a step smaller still, cannot either
            // (a no-step bound shrinks), so st decides as with the grid's bound.
            // With spectral MIS, st goes on in one channel where a step would fit the
            // extinction spectral_switch_extinction (below), which decides.
            const float sigma_step = spectral
                                         ? spectral_switch_extinction(s.medium.sigma_t)
                                         : extinction(s.medium, channel);
            float r = r_end;
            bool shrink = r < 0.f;
            if constexpr (kSphereTracing)
                shrink = shrink && query_shape == shape &&
                         sigma_step * query_cell_bound <
                             st_->threshold() + st_->clearance(shape) &&
                         grid.cell_of(o) == query_cell;
            if (shrink) {
                r = std::max(0.f, r_o - t * (1.f + 1e-6f) - grid.guard());
                r_shrunk = true;
            } else if (r < 0.f) {
                r = query(o);
            }
            if constexpr (kSphereTracing) {
                // Sphere tracing: if the largest sphere around o inside the medium is
                // optically thick enough, one step replaces every scattering event inside
                // it (docs/sphere-tracing.md). With spectral MIS the path stops carrying
                // all three channels where a step would fit spectral_switch_extinction,
                // so that where it does depends on where it is, not on its hero channel:
                // there it goes on in one channel, picked afresh, weight 3, and steps if
                // that channel's sphere is thick enough, else scatters at o as pt does
                // (docs/notation.md, "Colour").
                auto to_one_channel = [&]() {
                    if (!spectral) return;
                    const Vec3 w = weight();
                    channel = std::min(2, int(rng.uniform() * 3.f));
                    beta = Vec3(0.f);
                    beta[channel] = 3.f * w[channel];
                    ratio = Vec3(1.f);
                    spectral = false;
                    beta_start = 3.f;
                };
                // Where the step's events would need light sampling of point or
                // directional lights, the ball keeps clear of the boundary and of the
                // point lights (SphereTracing::clearance), measured in the extinction of
                // the channel the step would take.
                float r_step = st_->step_radius(shape, o, r, sigma_step);
                if (sigma_step * r_step >= st_->threshold()) {
                    bool step = true;
                    if (spectral) {
                        to_one_channel();
                        const float sigma_c = extinction(s.medium, channel);
                        r_step = st_->step_radius(shape, o, r, sigma_c);
                        step = sigma_c * r_step >= st_->threshold();
                    }
                    if (step) {
                        suspend();
                        request_step(ps, r_step);
                        return false;
                    }
                }
                // Too close to the boundary for a sphere: a cut sphere step where a plane
                // certifies the region between it and the boundary
                // (docs/sphere-tracing.md, "Cut sphere steps"). The collision at o is the
                // step's first event. The decision depends on o alone, so it is taken
                // before the channel is.
                Vec3 cut_n;
                float cut_s;
                if (st_->cuts(shape) && st_->cut_certificate(shape, o, &cut_n, &cut_s)) {
                    to_one_channel();
                    suspend();
                    request_cut_step(ps, cut_n, cut_s);
                    return false;
                }
            }
            r_at_o = r;  // the ordinary event below stays at o: its next flight reuses r
            // Real collision: scatter.
            if (max_bounces_ >= 0 && int(out.scatter_events) >= max_bounces_) break;
            ++out.scatter_events;
            beta *= s.medium.albedo;
            if (is_black(beta)) break;
            if (nee_ && !desc.lights.empty())
                L += weight() * direct_light(o, r_shrunk ? -1.f : r, d, shape,
                                             spectral ? -1 : channel, rng);
            Vec3 d_new = phase_sample(s.medium.phase, d, rng.uniform(), rng.uniform());
            phase_pdf = phase_eval(s.medium.phase, dot(d, d_new));
            scatter_pos = o;
            d = d_new;
            specular = false;
            if (!roulette()) break;
            continue;
        }

        // Reached a boundary from inside. Where the photon is after a crossing follows
        // from the crossing, never from distances: behind a front face of a shape it is
        // inside that shape, behind a back face outside it.
        if (int(hit.mesh) < scene_.num_shapes() && desc.shapes[hit.mesh].is_surface()) {
            // A surface in the medium, or (met first by rounding) one lying on its face
            if (Hit face;
                !s.boundary.passes_shadow_rays() && face_at(o, d, hit, shape, &face)) {
                if (!across_gap(face, hit, s.boundary)) break;
            } else if (!reflect(hit, desc.shapes[hit.mesh].surface)) {
                break;
            }
            continue;
        }
        if (int(hit.mesh) != shape || dot(d, hit.normal) <= 0.f) {
            // A crossing this state does not expect: a front face of our own shape (the
            // photon was outside after all, by rounding in a grazing hit), a face of
            // another shape (touching shapes) or an emitter's quad. Pass straight
            // through, into the shape the crossing enters, if any.
            if (dot(d, hit.normal) < 0.f && int(hit.mesh) < scene_.num_shapes())
                shape = int(hit.mesh);
            o = leave(hit, d);
            continue;
        }
        if (Hit on; scene_.surface_at(o, d, hit, &on)) {
            if (s.boundary.passes_shadow_rays()
                    ? !reflect(on, desc.shapes[on.mesh].surface)
                    : !across_gap(hit, on, s.boundary))
                break;
            continue;
        }
        if (!cross(hit, s.boundary)) break;
    }
    return finish();
}

}  // namespace sss

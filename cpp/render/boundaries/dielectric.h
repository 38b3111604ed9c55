// Dielectric boundary: x = the index of refraction inside over outside (`ior`, default
// 1.5), y = the GGX roughness alpha (`roughness`, Mitsuba 3's `alpha`, not remapped;
// default 0), z = the regularization alpha of a smooth one (`regularization`, default
// kDefaultRegularization).
// - Smooth (alpha = 0): Fresnel reflection or refraction, chosen with the Fresnel
//   reflectance as probability; total internal reflection from inside. A straight shadow
//   ray cannot pass it (docs/notation.md, "Next-event estimation"). With z > 0 its
//   meeting points sample point and directional lights as a rough interface of alpha z
//   would (path regularization, Kaplanyan and Dachsbacher 2013): the only way such
//   lights reach through it, consistent as z -> 0 (docs/notation.md, "Regularization");
//   the path itself goes on as on the smooth interface.
// - Rough (alpha > 0): the microfacet BSDF of Walter et al. 2007 with GGX normals and
//   Smith's separable masking (shared/ggx.h), reflection and transmission from both
//   sides. A visible normal is sampled, then reflection or refraction about it with the
//   Fresnel reflectance as probability: the weight is G1 of the outgoing direction. The
//   meeting point is a path vertex that samples lights (boundary_eval); point and
//   directional lights through a lobe of alpha z where alpha < z, as the smooth one's.
// Both leave out the radiance scaling by (eta_out / eta_in)^2 on transmission: the camera
// is outside every medium, so a path's scalings multiply to 1 / n^2 for its light's
// medium, which Scene::light_scale applies to a point light inside one (docs/notation.md,
// "No η² radiance scaling").
#ifndef SSS_RENDER_BOUNDARIES_DIELECTRIC_H
#define SSS_RENDER_BOUNDARIES_DIELECTRIC_H

#include "core/frame.h"
#include "render/boundaries/boundary.h"
#include "shared/fresnel.h"
#include "shared/ggx.h"

#ifdef __cplusplus
namespace sss {
#endif

// The rough BSDF in a local frame whose +z is the normal on wi's side (wi.z > 0); eta =
// the index on the far side over the index on wi's side.
SSS_FN BoundaryEval rough_dielectric_eval_local(Vec3 wi, Vec3 wo, float eta,
                                                float alpha) {
    if (!(wi.z > 0.f) || wo.z == 0.f) return no_boundary_eval();
    bool reflected = wo.z > 0.f;
    // The micro-normal that maps wi to wo: the half vector, or for refraction the
    // generalised one, on the +z side.
    Vec3 m = normalize(reflected ? wi + wo : wi + wo * eta);
    if (m.z < 0.f) m = -m;
    float ci = dot(wi, m), co = dot(wo, m);
    float g = ggx_g1(wi, m, alpha) * ggx_g1(wo, m, alpha);
    if (!(g > 0.f) || !(ci > 0.f)) return no_boundary_eval();
    float cos_t;
    // Refraction: wo gives the transmitted cosine, precisely even near the critical
    // angle.
    float F = reflected ? fresnel_dielectric(ci, eta, cos_t)
                        : fresnel_dielectric_cosines(ci, -co, eta);
    float d = ggx_d(m, alpha);
    BoundaryEval e;
    if (reflected) {
        e.f = F * d * g / (4.f * wi.z);
        e.pdf = F * ggx_visible_pdf(wi, m, alpha) / (4.f * co);
    } else {
        float denom = ci + eta * co;
        float jacobian = eta * eta * abs(co) / (denom * denom);  // dm / dwo
        e.f = (1.f - F) * d * g * ci * jacobian / wi.z;
        e.pdf = (1.f - F) * ggx_visible_pdf(wi, m, alpha) * jacobian;
    }
    if (!(e.pdf > 0.f) || !(e.f >= 0.f)) return no_boundary_eval();
    return e;
}

// The frame and relative index for a photon of direction d meeting the boundary of
// outward normal n: z along the normal on the photon's side.
SSS_FN Frame dielectric_side_frame(BoundaryData b, Vec3 d, Vec3 n, SSS_OUT(float) eta) {
    bool entering = dot(d, n) < 0.f;
    eta = entering ? b.x : 1.f / b.x;
    return frame_from_z(entering ? n : -n);
}

SSS_FN BoundaryEvent rough_dielectric_cross(BoundaryData b, Vec3 d, Vec3 n,
                                            SSS_INOUT(RngState) rng) {
    BoundaryEvent e = no_boundary_event(d);
    float eta;
    Frame f = dielectric_side_frame(b, d, n, eta);
    float alpha = max(b.y, kMinGgxAlpha);
    Vec3 wi = frame_to_local(f, -d);
    if (!(wi.z > 0.f)) return e;  // grazing
    float u1 = rng_uniform(rng), u2 = rng_uniform(rng);
    Vec3 m = ggx_sample_visible(wi, alpha, u1, u2);
    float ci = dot(wi, m);
    float cos_t;
    float F = fresnel_dielectric(max(ci, 0.f), eta, cos_t);
    bool reflected = rng_uniform(rng) < F;
    Vec3 wo =
        normalize(reflected ? m * (2.f * ci) - wi : m * (ci / eta - cos_t) - wi / eta);
    // The lobe's direction on the wrong side of the macro-surface (masked): no sample.
    if (reflected != (wo.z > 0.f)) return e;
    BoundaryEval ev = rough_dielectric_eval_local(wi, wo, eta, alpha);
    if (!(ev.pdf > 0.f)) return e;
    e.d = frame_to_world(f, wo);
    e.crossed = !reflected;
    e.weight = ggx_g1(wo, m, alpha);
    e.pdf = ev.pdf;
    return e;
}

// d: the photon's direction; n: the boundary's outward unit normal at the hit.
SSS_FN BoundaryEvent dielectric_boundary_cross(BoundaryData b, Vec3 d, Vec3 n,
                                               SSS_INOUT(RngState) rng) {
    if (b.y > 0.f) return rough_dielectric_cross(b, d, n, rng);
    BoundaryEvent e;
    e.specular = true;
    e.weight = 1.f;
    e.pdf = 0.f;
    // nf: the normal on the photon's side; eta_t / eta_i for Fresnel, eta_i / eta_t for
    // the refracted direction.
    bool entering = dot(d, n) < 0.f;
    Vec3 nf = entering ? n : -n;
    float eta = entering ? b.x : 1.f / b.x;
    float eta_inv = entering ? 1.f / b.x : b.x;
    float cos_i = -dot(d, nf);
    float cos_t;
    float F = fresnel_dielectric(cos_i, eta, cos_t);
    if (rng_uniform(rng) < F) {
        e.d = d + nf * (2.f * cos_i);
        e.crossed = false;
        return e;
    }
    e.d = normalize(d * eta_inv + nf * (eta_inv * cos_i - cos_t));
    e.crossed = true;
    return e;
}

// The photon arrived along d; wo leaves the hit point, towards a point or directional
// light if delta_light. 0 for the smooth interface (its lobes are deltas) unless
// regularized.
SSS_FN BoundaryEval dielectric_boundary_eval(BoundaryData b, Vec3 d, Vec3 wo, Vec3 n,
                                             bool delta_light) {
    // The rough interface's alpha, else the smooth one's regularization (0: none). A
    // delta light is reached through a lobe at least the regularization's wide: its
    // variance grows as 1 / alpha^2, and a rough interface of alpha 0.001 rendered 10x
    // too dark at practical spp (heavy tails) where the smooth one (alpha -> 0) renders
    // as alpha_r.
    float alpha = b.y > 0.f ? (delta_light ? max(b.y, b.z) : b.y) : b.z;
    if (!(alpha > 0.f)) return no_boundary_eval();
    float eta;
    Frame f = dielectric_side_frame(b, d, n, eta);
    return rough_dielectric_eval_local(frame_to_local(f, -d), frame_to_local(f, wo), eta,
                                       max(alpha, kMinGgxAlpha));
}

SSS_FN bool dielectric_boundary_passes_shadow_rays(BoundaryData b) { return false; }

// The medium's index of refraction over the outside's: `ior`.
SSS_FN float dielectric_boundary_index(BoundaryData b) { return b.x; }

// Which lights its vertices sample: a rough interface every light, a regularized smooth
// one the point and directional lights (area and environment lights reach it along the
// smooth interface's own directions, weighted 1).
SSS_FN int dielectric_boundary_light_sampling(BoundaryData b) {
    if (b.y > 0.f) return kSamplesAllLights;
    return b.z > 0.f ? kSamplesDeltaLights : kSamplesNoLights;
}

#ifdef __cplusplus
// An ior this close to 1, or closer, is no interface: the boundary is index-matched
// (parse_boundary). Such an interface reflects at most 2.5e-5 at normal incidence and
// reflects totally only within 8.1 degrees of grazing, but the lobe through which it
// passes point and directional light is |ior - 1| times its alpha wide: no light sample
// finds it, and the images were black (0 against 0.042 at ior 1.0001, 60 % dark at 1.01).
constexpr float kIorIndexMatched = 0.01f;

// The regularization alpha of a smooth interface unless the scene says otherwise
// (docs/notation.md, "Regularization", has the bias it gives).
constexpr float kDefaultRegularization = 0.05f;

inline BoundaryKind dielectric_boundary_kind() {
    BoundaryKind k;
    k.name = "dielectric";
    k.keys = {"ior", "roughness", "regularization"};
    k.parse = [](const json_fields::json& j, const json_fields::Field& f) {
        BoundaryData b{};
        b.x = 1.5f;
        b.z = kDefaultRegularization;
        if (j.contains("ior"))
            b.x = float(json_fields::number_in(j["ior"], f.at("ior"), 1e-3, 10.0,
                                               "a number in [0.001, 10]"));
        if (j.contains("roughness"))
            b.y = float(json_fields::number_in(
                j["roughness"], f.at("roughness"), 0.0, 1.0,
                "a number in [0, 1] (the GGX alpha; 0 is a smooth interface)"));
        if (j.contains("regularization"))
            b.z = float(json_fields::number_in(
                j["regularization"], f.at("regularization"), 0.0, 1.0,
                "a number in [0, 1] (the GGX alpha with which a smooth interface passes "
                "point and directional light; 0: it passes none)"));
        return b;
    };
    // Mitsuba 3's smooth dielectric has no regularization: point and directional lights
    // do not reach through it there.
    k.mitsuba = [](const json_fields::json& j) {
        const double alpha = j.value("roughness", 0.0);
        json_fields::json bsdf{{"type", alpha > 0.0 ? "roughdielectric" : "dielectric"},
                               {"int_ior", j.value("ior", 1.5)},
                               {"ext_ior", 1.0}};
        if (alpha > 0.0) {
            bsdf["distribution"] = "ggx";
            bsdf["alpha"] = alpha;
            bsdf["sample_visible"] = true;
        }
        return bsdf;
    };
    return k;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_BOUNDARIES_DIELECTRIC_H

// Smooth dielectric boundary: x = the index of refraction inside over outside (`ior`,
// default 1.5). Fresnel reflection or refraction, chosen with the Fresnel reflectance as
// probability; total internal reflection from inside. A straight shadow ray cannot pass
// it (docs/notation.md, "Next-event estimation").
#ifndef SSS_RENDER_BOUNDARIES_DIELECTRIC_H
#define SSS_RENDER_BOUNDARIES_DIELECTRIC_H

#include "render/boundaries/boundary.h"
#include "shared/fresnel.h"

#ifdef __cplusplus
namespace sss {
#endif

// d: the photon's direction; n: the boundary's outward unit normal at the hit.
SSS_FN BoundaryEvent dielectric_boundary_cross(BoundaryData b, Vec3 d, Vec3 n,
                                               SSS_INOUT(RngState) rng) {
    BoundaryEvent e;
    e.specular = true;
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

SSS_FN bool dielectric_boundary_passes_shadow_rays(BoundaryData b) { return false; }

#ifdef __cplusplus
inline BoundaryKind dielectric_boundary_kind() {
    BoundaryKind k;
    k.name = "dielectric";
    k.keys = {"ior"};
    k.parse = [](const json_fields::json& j, const json_fields::Field& f) {
        BoundaryData b{};
        b.x = 1.5f;
        if (j.contains("ior"))
            b.x = float(json_fields::number_in(j["ior"], f.at("ior"), 1e-3, 10.0,
                                               "a number in [0.001, 10]"));
        return b;
    };
    k.mitsuba = [](const json_fields::json& j) {
        return json_fields::json{
            {"type", "dielectric"}, {"int_ior", j.value("ior", 1.5)}, {"ext_ior", 1.0}};
    };
    return k;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_BOUNDARIES_DIELECTRIC_H

// Diffuse (Lambertian) surface: color = the reflectance (`reflectance`, RGB in [0, 1],
// default 0.5), the same on both sides of the mesh, so that an open mesh (a floor of two
// triangles) needs no orientation. Opaque: light leaves on the side it arrived from.
// Sampled with the cosine-weighted hemisphere, which is exact (weight = reflectance).
#ifndef SSS_RENDER_SURFACES_DIFFUSE_H
#define SSS_RENDER_SURFACES_DIFFUSE_H

#include "core/frame.h"
#include "render/surfaces/surface.h"
#include "shared/sampling.h"

#ifdef __cplusplus
namespace sss {
#endif

SSS_FN SurfaceEval diffuse_surface_eval(SurfaceData s, Vec3 wi, Vec3 wo, Vec3 n) {
    float ci = dot(wi, n), co = dot(wo, n);
    if (!(ci * co > 0.f)) return no_surface_eval();  // through the surface, or grazing
    SurfaceEval e;
    e.pdf = abs(co) * kInvPi;
    e.f = s.color * e.pdf;
    return e;
}

SSS_FN SurfaceSample diffuse_surface_sample(SurfaceData s, Vec3 wi, Vec3 n, float u1,
                                            float u2) {
    float ci = dot(wi, n);
    if (ci == 0.f) return no_surface_sample(wi);
    Vec3 nf = ci > 0.f ? n : -n;
    SurfaceSample smp;
    smp.wo =
        normalize(frame_to_world(frame_from_z(nf), sample_cosine_hemisphere(u1, u2)));
    smp.pdf = abs(dot(smp.wo, n)) * kInvPi;
    smp.weight = s.color;
    if (!(smp.pdf > 0.f)) return no_surface_sample(wi);
    return smp;
}

#ifdef __cplusplus
inline SurfaceKind diffuse_surface_kind() {
    using namespace json_fields;
    SurfaceKind k;
    k.name = "diffuse";
    k.keys = {"reflectance"};
    k.parse = [](const json& j, const Field& f) {
        SurfaceData s{};
        s.color = Vec3(0.5f);
        if (j.contains("reflectance"))
            s.color = rgb_in(j["reflectance"], f.at("reflectance"), 0.0, 1.0,
                             "each channel in [0, 1]");
        return s;
    };
    k.mitsuba = [](const json& j) {
        const json r = j.value("reflectance", json(0.5));
        return json{
            {"type", "twosided"},
            {"bsdf",
             {{"type", "diffuse"},
              {"reflectance", {{"$rgb", r.is_number() ? json::array({r, r, r}) : r}}}}}};
    };
    return k;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_SURFACES_DIFFUSE_H

// The GGX (Trowbridge-Reitz) microfacet distribution, isotropic with roughness alpha,
// in a local frame whose +z is the macro-surface normal: the distribution D, Smith's
// masking G1 (the separable form G = G1(wi) G1(wo), as Mitsuba 3), and sampling of the
// normals visible from a direction (Heitz 2018, "Sampling the GGX Distribution of
// Visible Normals"). Portable (core/portable.h).
#ifndef SSS_SHARED_GGX_H
#define SSS_SHARED_GGX_H

#ifdef __cplusplus
#include "core/portable.h"
#include "core/vec.h"
#include "shared/hg.h"  // kPi
namespace sss {
#endif

// Below this alpha the distribution is too narrow for float; it is raised to it (as in
// Mitsuba 3).
SSS_CONST float kMinGgxAlpha = 1e-4f;

// D(m) for a unit micro-normal m (m.z > 0; 0 below the surface).
SSS_FN float ggx_d(Vec3 m, float alpha) {
    if (!(m.z > 0.f)) return 0.f;
    float a2 = alpha * alpha;
    float t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    return 1.f / (kPi * a2 * t * t);
}

// Smith's G1 for unit direction v and micro-normal m: 0 when v sees the back of m or m
// from below the surface (v . m and v.z of opposite signs).
SSS_FN float ggx_g1(Vec3 v, Vec3 m, float alpha) {
    if (!(dot(v, m) * v.z > 0.f)) return 0.f;
    float xy = alpha * alpha * (v.x * v.x + v.y * v.y);
    if (xy == 0.f) return 1.f;
    return 2.f / (1.f + sqrt(1.f + xy / (v.z * v.z)));
}

// The density of visible normals seen from wi (wi.z > 0): G1(wi, m) (wi . m)+ D(m) /
// wi.z, per unit solid angle of m.
SSS_FN float ggx_visible_pdf(Vec3 wi, Vec3 m, float alpha) {
    return ggx_g1(wi, m, alpha) * max(dot(wi, m), 0.f) * ggx_d(m, alpha) / wi.z;
}

// A micro-normal drawn with ggx_visible_pdf from uniforms u1, u2 (wi.z > 0): the
// hemisphere stretched by alpha, a point of the projected disc it shows to wi, lifted
// and unstretched.
SSS_FN Vec3 ggx_sample_visible(Vec3 wi, float alpha, float u1, float u2) {
    Vec3 v = normalize(Vec3(alpha * wi.x, alpha * wi.y, wi.z));
    float len2 = v.x * v.x + v.y * v.y;
    Vec3 t1 = len2 > 0.f ? Vec3(-v.y, v.x, 0.f) / sqrt(len2) : Vec3(1.f, 0.f, 0.f);
    Vec3 t2 = cross(v, t1);
    float r = sqrt(u1), phi = 2.f * kPi * u2;
    float p1 = r * cos(phi), p2 = r * sin(phi);
    float s = 0.5f * (1.f + v.z);
    p2 = (1.f - s) * sqrt(max(0.f, 1.f - p1 * p1)) + s * p2;
    Vec3 h = t1 * p1 + t2 * p2 + v * sqrt(max(0.f, 1.f - p1 * p1 - p2 * p2));
    return normalize(Vec3(alpha * h.x, alpha * h.y, max(h.z, 0.f)));
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_GGX_H

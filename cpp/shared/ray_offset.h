// Robust ray origins on triangles (docs/robustness.md), as in pbrt-v4 (Pharr, Jakob and
// Humphreys, "Physically Based Rendering", 4th ed., "Managing Rounding Error"): the hit
// point is rebuilt from the triangle and the hit's barycentric coordinates, with a bound
// on its rounding error; a ray leaving it starts just past that bound along the normal,
// on the side it travels to. No absolute epsilon: the offset follows the magnitude of the
// coordinates, so a scene scaled by any k gets offsets scaled by k. Portable
// (core/portable.h).
#ifndef SSS_SHARED_RAY_OFFSET_H
#define SSS_SHARED_RAY_OFFSET_H

#ifdef __cplusplus
#include "core/portable.h"
#include "core/vec.h"
namespace sss {
#endif

// gamma(7) = 7 u / (1 - 7 u), u = 2^-24: bounds the relative error of a few float
// operations (pbrt's gamma(n)); seven covers the hit point's products and sums with room
// for the edge vectors' own rounding.
SSS_CONST float kGamma7 = 4.1723268e-07f;

// The point v0 + b1 e1 + b2 e2 of the triangle with corner v0 and edges e1 = v1 - v0,
// e2 = v2 - v0 (barycentric coordinates (1 - b1 - b2, b1, b2)), and in `error` a bound on
// each coordinate's distance to the triangle's plane caused by rounding.
SSS_FN Vec3 triangle_point(Vec3 v0, Vec3 e1, Vec3 e2, float b1, float b2,
                           SSS_OUT(Vec3) error) {
    Vec3 a = e1 * b1, b = e2 * b2;
    error = (abs(v0) + abs(a) + abs(b)) * kGamma7;
    return v0 + a + b;
}

// The origin of a ray leaving point p (with rounding-error bound `error`) of a surface
// with unit normal n in direction w: p moved along n, to w's side, by the error bound's
// extent along n, then rounded away from p so that the sum's own rounding cannot bring it
// back. The ray then starts strictly on w's side of the surface's plane.
//
// A plane normal to an axis through that axis' 0 (a floor at y = 0 of the render frame)
// has a hit point exact along n: the bound there is 0, and a ray from p itself would meet
// the plane again at t = 0. Such a point moves by the bound of the other coordinates
// instead, which still follows the scene's scale.
SSS_FN Vec3 offset_ray_origin(Vec3 p, Vec3 error, Vec3 n, Vec3 w) {
    float d = dot(abs(n), error);
    if (!(d > 0.f)) d = max(error.x, max(error.y, error.z));
    Vec3 offset = n * (dot(w, n) < 0.f ? -d : d);
    Vec3 o = p + offset;
    o.x = offset.x > 0.f ? next_float_up(o.x)
                         : (offset.x < 0.f ? next_float_down(o.x) : o.x);
    o.y = offset.y > 0.f ? next_float_up(o.y)
                         : (offset.y < 0.f ? next_float_down(o.y) : o.y);
    o.z = offset.z > 0.f ? next_float_up(o.z)
                         : (offset.z < 0.f ? next_float_down(o.z) : o.z);
    return o;
}

// How far along a ray (origin o, unit direction d) that hit a triangle of unit normal n
// at distance t, at a point with error bound `error`, something else the ray met there by
// rounding can lie (a floor under the face of a cube resting on it): to the plane of the
// origin of a ray leaving the hit on the far side (offset_ray_origin's offset, twice,
// over |cos|; at grazing incidence, 1000 times the offset), and the hit distances' own
// rounding, which grows with the origin's coordinates (a camera far away).
SSS_FN float tie_reach(Vec3 o, Vec3 d, float t, Vec3 error, Vec3 n) {
    float offset = dot(abs(n), error);
    if (!(offset > 0.f)) offset = max(error.x, max(error.y, error.z));
    float cos_d = max(abs(dot(d, n)), 1e-3f);
    float o_max = max(abs(o.x), max(abs(o.y), abs(o.z)));
    return t + 2.002f * offset / cos_d + 1e-6f * (o_max + t);
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_RAY_OFFSET_H

// The geometry of one cut sphere step (docs/notation.md, "The cut sphere problem";
// nn/cut_step_model.h says in which order a step uses it). Value in, value out, and
// portable (core/portable.h): CutStepModel and the shaders (gpu/shaders/cut_model.glsl)
// compile the same code.
//
// The walk's frame: the unit ball about the photon, the plane z = h (0 < h <= 1), the
// medium z < h. A direction P from the centre meets the region's boundary on the plane
// where P.z > h, else on the cap.
#ifndef SSS_SHARED_CUT_STEP_H
#define SSS_SHARED_CUT_STEP_H

#ifdef __cplusplus
#include "core/portable.h"
#include "core/vec.h"
namespace sss {
#endif

// The frame of the exit surface at the exit point in direction P (unit): on the plane n =
// +z, t the radial direction (P.x, P.y, 0) / rho, b = n x t; on the cap n = P, b = (-P.y,
// P.x, 0) / rho, t = b x n; (+x, +y) for the radial direction where rho = 0.
struct CutExitFrame {
    Vec3 t, b, n;
};

SSS_FN CutExitFrame cut_exit_frame(Vec3 P, bool plane) {
    float rho = sqrt(P.x * P.x + P.y * P.y);
    Vec3 radial = rho > 1e-12f ? Vec3(P.x / rho, P.y / rho, 0.f) : Vec3(1.f, 0.f, 0.f);
    CutExitFrame f;
    f.b = Vec3(-radial.y, radial.x, 0.f);  // z x radial
    f.n = plane ? Vec3(0.f, 0.f, 1.f) : P;
    f.t = plane ? radial : cross(f.b, P);
    return f;
}

// v / |v| (the length in real), or `fallback` for a zero or non-finite v.
SSS_FN Vec3 unit_or(Vec3 v, Vec3 fallback) {
    real x = real(v.x), y = real(v.y), z = real(v.z), l = sqrt(x * x + y * y + z * z);
    if (!(l > real(0) && l < real(kInf))) return fallback;
    return Vec3(float(x / l), float(y / l), float(z / l));
}

// How far the first flight from the centre along w (unit) may go before it leaves the
// region: to the plane where w.z > h, else to the cap. A flight t >= this leaves with N =
// 1, at w times it, along w.
SSS_FN float cut_first_exit(Vec3 w, float h) { return w.z > h ? h / w.z : 1.f; }

// The networks' exit, decoded and made valid (cos_p and cos_psi in [-1, 1], (alpha, beta)
// in the unit disc), in the half y >= 0: the direction P of the exit point from the
// centre and the direction D there, alpha t + beta b + sqrt(1 - alpha^2 - beta^2) n in
// the exit frame of P.
SSS_FN void cut_network_exit(float cos_p, float cos_psi, float alpha, float beta, float h,
                             SSS_OUT(Vec3) P, SSS_OUT(Vec3) D) {
    float sin_p = sqrt(max(0.f, 1.f - cos_p * cos_p));
    float sin_psi = sqrt(max(0.f, 1.f - cos_psi * cos_psi));
    P = Vec3(sin_p * cos_psi, sin_p * sin_psi, cos_p);
    CutExitFrame f = cut_exit_frame(P, cos_p > h);
    float gamma = sqrt(max(0.f, 1.f - alpha * alpha - beta * beta));
    D = unit_or(f.t * alpha + f.b * beta + f.n * gamma, f.n);
}

// The step's exit from the direction P of the exit point and the direction D there: the
// region's boundary in direction P (on the plane at P h / P.z where P.z > h, else P), and
// D, reflected about that boundary's tangent plane where rounding turned it inwards.
struct CutExit {
    Vec3 pos, dir;
    bool through_plane;
};

SSS_FN CutExit cut_exit(Vec3 P, Vec3 D, float h) {
    CutExit e;
    e.through_plane = P.z > h;
    Vec3 normal = P;
    if (e.through_plane) {
        e.pos = P * (h / P.z);
        e.pos.z = h;
        normal = Vec3(0.f, 0.f, 1.f);
    } else {
        e.pos = P;
    }
    float dn = dot(D, normal);
    e.dir = dn < 0.f ? unit_or(D - normal * (2.f * dn), normal) : D;
    return e;
}

#ifdef __cplusplus
}  // namespace sss
#endif
#endif  // SSS_SHARED_CUT_STEP_H

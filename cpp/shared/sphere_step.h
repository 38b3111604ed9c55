// The geometry and weights of one sphere step (docs/sphere-tracing.md; docs/notation.md
// "The exit frame", docs/sphere-tracing.md). Value in, value out, and portable
// (core/portable.h): the shaders compile it too.
//
// The canonical step is a unit sphere entered at its centre travelling +z. Its exit frame
// puts the exit point at x = (sin theta, 0, cos theta), with n = x, b = +y, t = b x n =
// (cos theta, 0, -sin theta), and the exit direction w = alpha b + beta t + sqrt(1 - a^2
// - b^2) n. In a scene the canonical z is the path's direction w_in, the canonical x and
// y an orthonormal completion of it turned by a uniform angle psi about w_in, and lengths
// scale by the radius.
#ifndef SSS_SHARED_SPHERE_STEP_H
#define SSS_SHARED_SPHERE_STEP_H

#ifdef __cplusplus
#include "core/frame.h"
#include "core/portable.h"
#include "core/vec.h"
#include "shared/hg.h"
namespace sss {
#endif

// Exit point on the unit sphere, exit frame.
SSS_FN Vec3 sphere_exit_point(float cos_theta) {
    float sin_theta = sqrt(max(0.f, 1.f - cos_theta * cos_theta));
    return Vec3(sin_theta, 0.f, cos_theta);
}

// Exit direction alpha b + beta t + sqrt(1 - alpha^2 - beta^2) n, exit frame; unit length
// for alpha^2 + beta^2 <= 1.
SSS_FN Vec3 sphere_exit_direction(float cos_theta, float alpha, float beta) {
    float sin_theta = sqrt(max(0.f, 1.f - cos_theta * cos_theta));
    float gamma = sqrt(max(0.f, 1.f - alpha * alpha - beta * beta));
    return Vec3(beta * cos_theta + gamma * sin_theta, alpha,
                gamma * cos_theta - beta * sin_theta);
}

// The world frame of a step: z = w_in (unit), x and y frame_from_z(w_in)'s completion
// turned by psi = 2 pi u about w_in. frame_to_world maps exit-frame vectors into the
// world.
SSS_FN Frame sphere_step_frame(Vec3 w_in, float u) {
    Frame f = frame_from_z(w_in);
    float psi = 2.f * kPi * u;
    float c = cos(psi), s = sin(psi);
    Frame r;
    r.s = f.s * c + f.t * s;
    r.t = f.t * c - f.s * s;
    r.n = f.n;
    return r;
}

// StepNee::Hits: a step's events sample no light; the exit flight brings them the light
// of area lights and the environment, but no flight reaches a point or directional light.
// So where a medium's events would sample such lights, a step's ball keeps this many mean
// free paths from the boundary and from every point light, and its events' connections
// are left out: each would cross at least that optical depth of the medium, a
// transmittance below e^-10 = 4.5e-5 (docs/sphere-tracing.md, "Point and directional
// lights: clearance").
SSS_CONST float kDeltaLightClearance = 10.f;

// Where a path that carries three channels with spectral MIS goes on in one ("st";
// docs/notation.md, "Colour"): at a collision whose ball is a step for this extinction.
// It depends on the medium alone, not on the hero channel, which keeps the MIS unbiased.
// Channels within a factor kSpectralSwitchRatio of each other: the smallest, so that the
// channel picked there can always step. Further apart: the largest over that factor, so
// that a thin channel (skin's red) does not keep a dense one (its blue) from ever
// stepping; a channel picked there that is too thin for the ball scatters as in "pt".
// Two is measured (docs/sphere-tracing.md, "Colour"): switching wherever the densest
// channel could step made near-grey media (marble, milk) 10-15 % less efficient, with
// more colour noise than time saved.
SSS_CONST float kSpectralSwitchRatio = 2.f;
SSS_FN float spectral_switch_extinction(Vec3 sigma_t) {
    return max(min(sigma_t.x, min(sigma_t.y, sigma_t.z)),
               max(sigma_t.x, max(sigma_t.y, sigma_t.z)) / kSpectralSwitchRatio);
}

// The radius of the ball a step at a collision may take, given the grid's bound r there,
// the distance to the nearest point light (kInf: none) and the clearance in mean free
// paths of extinction sigma. Negative: no ball.
SSS_FN float cleared_step_radius(float r, float light_dist, float clearance,
                                 float sigma) {
    return min(r, light_dist) - clearance / sigma;
}

// The decoders' outputs (finite) made valid: (alpha, beta) into the unit disc, X into the
// unit ball, W to unit length. A point outside is scaled onto the circle or sphere and
// then nudged inside against rounding. The lengths are taken of the components divided by
// the largest of them, so that nothing overflows in float (the GPU's real).
SSS_FN void project_into_disc(SSS_INOUT(float) a, SSS_INOUT(float) b) {
    real m = max(abs(real(a)), abs(real(b)));
    if (!(m > real(0))) return;
    real x = real(a) / m, y = real(b) / m, s = x * x + y * y;  // s in [1, 2]
    if (s * m * m <= real(1)) return;  // inside (in float m * m may round to 0 or inf)
    real l = sqrt(s);
    a = float(x / l);
    b = float(y / l);
    while (a * a + b * b > 1.f) {
        a *= 0.99999994f;
        b *= 0.99999994f;
    }
}

SSS_FN Vec3 project_into_ball(Vec3 v) {
    real m = max(abs(real(v.x)), max(abs(real(v.y)), abs(real(v.z))));
    if (!(m > real(0))) return v;
    real x = real(v.x) / m, y = real(v.y) / m, z = real(v.z) / m,
         s = x * x + y * y + z * z;
    if (s * m * m <= real(1)) return v;
    real l = sqrt(s);
    Vec3 r = Vec3(float(x / l), float(y / l), float(z / l));
    while (dot(r, r) > 1.f) r *= 0.99999994f;
    return r;
}

// v / |v|, or +z for v = 0.
SSS_FN Vec3 unit_or_z(Vec3 v) {
    real m = max(abs(real(v.x)), max(abs(real(v.y)), abs(real(v.z))));
    if (!(m > real(0))) return Vec3(0.f, 0.f, 1.f);
    real x = real(v.x) / m, y = real(v.y) / m, z = real(v.z) / m;
    real l = sqrt(x * x + y * y + z * z);
    return Vec3(float(x / l), float(y / l), float(z / l));
}

// PathGen's forward-memory tilt (docs/sphere-tracing.md, "The forward-memory tilt"): a
// learned step (N >= 2) is kept with probability tilt_acceptance and otherwise drawn
// again (LengthGen and PathGen), which reweights the decoders' law by 1 + a cos_theta + b
// w_z, w_z the exit direction's z: the part of the entering direction the step keeps. a
// and b are calibrated per (sigma, g) so that the means of cos_theta and w_z are those of
// exact walks (models/tilt.json, docs/model-format.md).
//
// The largest value of a cos_theta + b w_z over the exits a step can have: an exit
// direction points out of the sphere, so w_z <= sqrt(1 - cos_theta^2) where cos_theta < 0
// and w_z >= -sqrt(1 - cos_theta^2) where cos_theta > 0; over that set the maximum is |a|
// + |b| (a corner) when a and b have one sign, and sqrt(a^2 + b^2) (on an arc) otherwise.
SSS_FN float tilt_bound(float a, float b) {
    return a * b >= 0.f ? abs(a) + abs(b) : sqrt(a * a + b * b);
}
SSS_FN float tilt_acceptance(float cos_theta, float alpha, float beta, float a, float b) {
    float w_z = sphere_exit_direction(cos_theta, alpha, beta).z;
    return (1.f + a * cos_theta + b * w_z) / (1.f + tilt_bound(a, b));
}
// A step drawn this many times is kept. The shipped table refuses at most 35 % of the
// draws (sigma = 3, g = 0.95; 30 % at sigma = 6), so every draw is refused with a
// probability below 1e-14.
SSS_CONST int kTiltMaxDraws = 32;

// phi^N: the probability that a walk of N events survives absorption (phi in [0, 1]).
// log1p(phi - 1) rather than log(phi): phi - 1 is exact, and for albedos near 1 a float
// log (the GPU's) would be about 1 % off at phi = 0.99995.
SSS_FN real survival_power(real phi, real n) {
    if (phi >= real(1)) return real(1);
    if (phi <= real(0)) return real(0);
    return exp(n * log1p(phi - real(1)));
}

// Lambda = sum_{j=1..N} phi^j = phi (1 - phi^N) / (1 - phi) (N at phi = 1): the weight of
// the step's one light connection from its representative event.
SSS_FN real event_weight_sum(real phi, real n) {
    if (phi >= real(1)) return n;
    if (phi <= real(0)) return real(0);
    return phi * -expm1(n * log1p(phi - real(1))) / (real(1) - phi);
}

// The probability that the step's first event (its centre) is the representative one:
// phi / Lambda = (1 - phi) / (1 - phi^N) (1/N at phi = 1). EventGen models only the
// events k >= 2 (docs/model-format.md).
SSS_FN real first_event_probability(real phi, real n) {
    if (phi >= real(1)) return real(1) / n;
    return (real(1) - phi) / -expm1(n * log1p(phi - real(1)));
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_SPHERE_STEP_H

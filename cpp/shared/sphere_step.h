// The geometry and weights of one sphere step (DESIGN §5; docs/notation.md "The exit
// frame", docs/sphere-tracing.md). Value in, value out, so the GPU path can share it.
//
// The canonical step is a unit sphere entered at its centre travelling +z. Its exit frame
// puts the exit point at x = (sin theta, 0, cos theta), with n = x, b = +y, t = b x n =
// (cos theta, 0, -sin theta), and the exit direction w = alpha b + beta t + sqrt(1 - a^2
// - b^2) n. In a scene the canonical z is the path's direction w_in, the canonical x and
// y an orthonormal completion of it turned by a uniform angle psi about w_in, and lengths
// scale by the radius.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/frame.h"
#include "core/vec.h"
#include "shared/hg.h"

namespace sss {

// Exit point on the unit sphere, exit frame.
inline Vec3 sphere_exit_point(float cos_theta) {
    float sin_theta = std::sqrt(std::max(0.f, 1.f - cos_theta * cos_theta));
    return {sin_theta, 0.f, cos_theta};
}

// Exit direction alpha b + beta t + sqrt(1 - alpha^2 - beta^2) n, exit frame; unit length
// for alpha^2 + beta^2 <= 1.
inline Vec3 sphere_exit_direction(float cos_theta, float alpha, float beta) {
    float sin_theta = std::sqrt(std::max(0.f, 1.f - cos_theta * cos_theta));
    float gamma = std::sqrt(std::max(0.f, 1.f - alpha * alpha - beta * beta));
    return {beta * cos_theta + gamma * sin_theta, alpha,
            gamma * cos_theta - beta * sin_theta};
}

// The world frame of a step: z = w_in (unit), x and y Frame::from_z(w_in)'s completion
// turned by psi = 2 pi u about w_in. to_world maps exit-frame vectors into the world.
inline Frame sphere_step_frame(Vec3 w_in, float u) {
    Frame f = Frame::from_z(w_in);
    float psi = 2.f * kPi * u;
    float c = std::cos(psi), s = std::sin(psi);
    Frame r;
    r.s = f.s * c + f.t * s;
    r.t = f.t * c - f.s * s;
    r.n = f.n;
    return r;
}

// phi^N: the probability that a walk of N events survives absorption (phi in [0, 1]).
inline double survival_power(double phi, int64_t n) {
    if (phi >= 1.0) return 1.0;
    if (phi <= 0.0) return 0.0;
    return std::exp(double(n) * std::log(phi));
}

// Lambda = sum_{j=1..N} phi^j = phi (1 - phi^N) / (1 - phi) (N at phi = 1): the weight of
// the step's one light connection from its representative event.
inline double event_weight_sum(double phi, int64_t n) {
    if (phi >= 1.0) return double(n);
    if (phi <= 0.0) return 0.0;
    return phi * -std::expm1(double(n) * std::log(phi)) / (1.0 - phi);
}

}  // namespace sss

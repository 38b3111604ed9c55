// Sampling routines in threes where it helps (sample / pdf), all with uniforms in [0, 1).
#pragma once

#include <cmath>

#include "core/vec.h"
#include "shared/hg.h"

namespace sss {

// Free-flight distance in a homogeneous medium: t = -ln(1 - u) / sigma_t, pdf sigma_t
// e^{-sigma_t t}.
inline float sample_exponential(float u, float sigma_t) {
    return -std::log1p(-u) / sigma_t;
}

inline Vec3 sample_uniform_sphere(float u1, float u2) {
    float z = 1.f - 2.f * u1;
    float r = std::sqrt(std::max(0.f, 1.f - z * z));
    float phi = 2.f * kPi * u2;
    return {r * std::cos(phi), r * std::sin(phi), z};
}
constexpr float uniform_sphere_pdf() { return kInvFourPi; }

// Power heuristic (beta = 2) for two strategies with one sample each.
inline float power_heuristic(float pdf_a, float pdf_b) {
    float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    return a + b > 0.f ? a / (a + b) : 0.f;
}

}  // namespace sss

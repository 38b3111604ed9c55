// Sampling routines in threes where it helps (sample / pdf), all with uniforms in [0, 1).
// Portable (core/portable.h).
#ifndef SSS_SHARED_SAMPLING_H
#define SSS_SHARED_SAMPLING_H

#ifdef __cplusplus
#include "core/portable.h"
#include "core/vec.h"
#include "shared/hg.h"
namespace sss {
#endif

// Free-flight distance in a homogeneous medium: t = -ln(1 - u) / sigma_t, pdf sigma_t
// e^{-sigma_t t}. For the stream's uniforms (multiples of 2^-24) 1 - u is exact, so the
// CPU takes the log of it: as accurate as log1p(-u) and a third of its time in glibc
// (bench/README.md, "Free flights by logf"). GLSL's log is not accurate near 1: the
// shaders keep log1p (gpu/shaders/portable.glsl).
SSS_FN float sample_exponential(float u, float sigma_t) {
#ifdef __cplusplus
    return -std::log(1.f - u) / sigma_t;
#else
    return -log1p(-u) / sigma_t;
#endif
}

SSS_FN Vec3 sample_uniform_sphere(float u1, float u2) {
    float z = 1.f - 2.f * u1;
    float r = sqrt(max(0.f, 1.f - z * z));
    float phi = 2.f * kPi * u2;
    return Vec3(r * cos(phi), r * sin(phi), z);
}
SSS_FN float uniform_sphere_pdf() { return kInvFourPi; }

// Cosine-weighted direction about +z (Malley: a uniform point of the unit disc lifted
// onto the hemisphere); pdf cos(theta) / pi.
SSS_CONST float kInvPi = 0.3183098861837907f;
SSS_FN Vec3 sample_cosine_hemisphere(float u1, float u2) {
    float r = sqrt(u1), phi = 2.f * kPi * u2;
    return Vec3(r * cos(phi), r * sin(phi), sqrt(max(0.f, 1.f - u1)));
}

// Russian roulette with survival probability q, decided by u in [0, 1): the weight 1/q if
// the sample survives, 0 if not. u can be exactly 0, so a survivor of a tiny q would get
// a weight that overflows to inf (and 0 * inf = NaN downstream): below kMinRouletteQ the
// sample is always dropped, a bias below 1e-20 of the quantity played for.
SSS_CONST float kMinRouletteQ = 1e-20f;
SSS_FN float roulette_weight(float q, float u) {
    if (q >= 1.f) return 1.f;
    return q >= kMinRouletteQ && u < q ? 1.f / q : 0.f;
}

// Power heuristic (beta = 2) for two strategies with one sample each.
SSS_FN float power_heuristic(float pdf_a, float pdf_b) {
    float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    if (a + b >= kFloatMinNormal && a + b <= kFloatMax) return a / (a + b);
    // The squares left float's normal range: a small light far away has a pdf past
    // 1.8e19 (inf / inf gave NaN pixels), a huge one close by below 1e-19 (0 / 0 gave
    // both strategies weight 0). The pdfs' ratio decides alone.
    float m = max(pdf_a, pdf_b);
    if (!(m > 0.f)) return 0.f;
    if (m > kFloatMax) return pdf_a < m ? 0.f : (pdf_b < m ? 1.f : 0.5f);
    a = pdf_a / m;
    b = pdf_b / m;
    return a * a / (a * a + b * b);
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_SAMPLING_H

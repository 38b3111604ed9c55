// Path bookkeeping both integrators (CPU and GLSL) share: Russian roulette of a path,
// Beer's law, and the solid-angle pdf of a point on an area light. Portable
// (core/portable.h). docs/notation.md ("Path Russian roulette", "Shadow-ray Russian
// roulette") gives the estimators.
#ifndef SSS_SHARED_PATH_H
#define SSS_SHARED_PATH_H

#ifdef __cplusplus
#include "core/portable.h"
#include "core/rng.h"
#include "core/vec.h"
namespace sss {
#endif

// Russian roulette starts once the throughput fell below this fraction of its start
// value.
SSS_CONST float kRouletteThreshold = 0.1f;
// Shadow rays whose transmittance is bounded (by the distance grid) below this value are
// traced with probability bound / kShadowRoulette and reweighted: unbiased, and it skips
// almost every shadow ray deep inside a dense medium. 0.1 by measurement
// (docs/notation.md): the image variance barely changes, the time drops.
SSS_CONST float kShadowRoulette = 0.1f;
// Shadow rays cross at most this many boundaries (then the light counts as blocked).
SSS_CONST int kMaxShadowCrossings = 64;
// A shadow ray from a scattering event is sphere traced through the distance grid, at
// most this many queries in all (the one at the event included) and no further than this
// optical depth, to bound its transmittance before it is traced (docs/notation.md,
// "Shadow-ray Russian roulette").
SSS_CONST int kShadowMarchQueries = 4;
SSS_CONST float kShadowMarchDepth = 16.f;

// The probability the shadow-ray roulette keeps a ray whose transmittance is at most
// `bound`.
SSS_FN float shadow_keep_probability(float bound) {
    return bound < kShadowRoulette ? bound / kShadowRoulette : 1.f;
}
// The probability a second roulette keeps a ray that a first one kept with probability
// `kept` (> 0) on a looser bound: both together keep it with
// shadow_keep_probability(bound).
SSS_FN float shadow_keep_again(float bound, float kept) {
    return min(1.f, shadow_keep_probability(bound) / kept);
}

// Path Russian roulette after a scattering event or sphere step, once the throughput fell
// below kRouletteThreshold of its start value (one uniform drawn then, none otherwise):
// false ends the path; a survivor's throughput is divided by its survival probability.
SSS_FN bool survives_roulette(SSS_INOUT(Vec3) beta, float beta_start,
                              SSS_INOUT(RngState) rng) {
    float q = max(beta.x, max(beta.y, beta.z)) / beta_start;
    if (q < kRouletteThreshold) {
        if (rng_uniform(rng) >= q) return false;
        beta = beta / q;
    }
    return true;
}

// Spectral MIS (docs/notation.md, "Colour"): a free flight of length dist sampled with
// the hero channel's extinction changes each channel's pdf of the path, relative to the
// hero's, and so the path's throughput, by exp(-(sigma_t - sigma_h) dist), times
// sigma_t / sigma_h where the flight ends in a collision. The hero's factor is exactly 1.
SSS_FN Vec3 hero_flight_ratio(Vec3 sigma_t, int hero, float dist, bool collision) {
    float sigma_h = sigma_t[hero];
    Vec3 f = Vec3(1.f, 1.f, 1.f);
    for (int c = 0; c < 3; ++c) {
        if (c == hero) continue;
        f[c] = exp(-(sigma_t[c] - sigma_h) * dist);
        if (collision) f[c] *= sigma_t[c] / sigma_h;
    }
    return f;
}

// Transmittance exp(-sigma_t d) per channel; a zero extinction gives 1 even for d = inf.
SSS_FN Vec3 beer(Vec3 sigma_t, float d) {
    Vec3 tr = Vec3(1.f, 1.f, 1.f);
    if (sigma_t.x > 0.f) tr.x = exp(-sigma_t.x * d);
    if (sigma_t.y > 0.f) tr.y = exp(-sigma_t.y * d);
    if (sigma_t.z > 0.f) tr.z = exp(-sigma_t.z * d);
    return tr;
}

// The solid-angle pdf, at a point distance t away along unit w, of a uniform point on an
// area light of that area and unit normal n (0 seen edge-on).
SSS_FN float area_light_pdf(float area, Vec3 w, float t, Vec3 n) {
    float cos_l = abs(dot(w, n));
    return cos_l > 0.f ? t * t / (cos_l * area) : 0.f;
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_PATH_H

// Henyey-Greenstein phase function. Direction convention (docs/notation.md): `cos_theta`
// is the cosine between the direction the photon travels *before* scattering and the one
// it travels *after*; g > 0 scatters forward. The phase function is normalised over the
// sphere: integral of hg_eval over all directions = 1. Portable (core/portable.h).
#ifndef SSS_SHARED_HG_H
#define SSS_SHARED_HG_H

#ifdef __cplusplus
#include "core/frame.h"
#include "core/portable.h"
#include "core/vec.h"
namespace sss {
#endif

SSS_CONST float kInvFourPi = 0.07957747154594767f;
SSS_CONST float kPi = 3.14159265358979323846f;
// Below this |g| the phase function is sampled as isotropic (the inversion is
// ill-conditioned).
SSS_CONST float kHgIsotropicG = 1e-3f;

SSS_FN float hg_eval(float cos_theta, float g) {
    // 1 + g^2 - 2 g cos as a sum of terms that cannot cancel: computed directly it rounds
    // to 0 or below near cos = +-1 once |g| > 0.999 (inf or NaN pixels). It is then at
    // least (1 - |g|)^2 > 0. cos_theta, a dot product, may pass 1 by a rounding.
    cos_theta = clamp(cos_theta, -1.f, 1.f);
    float denom = g >= 0.f ? (1.f - g) * (1.f - g) + 2.f * g * (1.f - cos_theta)
                           : (1.f + g) * (1.f + g) - 2.f * g * (1.f + cos_theta);
    return kInvFourPi * (1.f - g) * (1.f + g) / (denom * sqrt(denom));
}

// Cosine between travel directions drawn from HG by inverting its CDF with u in [0, 1).
SSS_FN float hg_sample_cos(float u, float g) {
    if (abs(g) < kHgIsotropicG) return 1.f - 2.f * u;
    float sq = (1.f - g * g) / (1.f - g + 2.f * g * u);
    float c = (1.f + g * g - sq * sq) / (2.f * g);
    return clamp(c, -1.f, 1.f);
}

// New travel direction for a photon travelling along unit `wi`; returns it, pdf =
// hg_eval.
SSS_FN Vec3 hg_sample(Vec3 wi, float g, float u1, float u2) {
    float c = hg_sample_cos(u1, g);
    float s = sqrt(max(0.f, 1.f - c * c));
    float phi = 2.f * kPi * u2;
    return frame_to_world(frame_from_z(wi), Vec3(s * cos(phi), s * sin(phi), c));
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_HG_H

// Fresnel reflectance of a smooth dielectric interface for unpolarised light. Portable
// (core/portable.h).
#ifndef SSS_SHARED_FRESNEL_H
#define SSS_SHARED_FRESNEL_H

#ifdef __cplusplus
#include "core/portable.h"
namespace sss {
#endif

// The reflectance from both cosines, cos_t being what Snell's law gives for cos_i (eta:
// n_transmitted / n_incident): where a refracted direction is known, this avoids
// computing cos_t as sqrt(1 - sin^2), which loses precision near the critical angle.
SSS_FN float fresnel_dielectric_cosines(float cos_i, float cos_t, float eta) {
    float r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5f * (r_par * r_par + r_perp * r_perp);
}

// cos_i: cosine between the incident travel direction reversed and the normal on the
// incident side (> 0). eta: n_transmitted / n_incident. Returns the reflectance R in [0,
// 1] and sets the transmitted cosine cos_t (> 0); R = 1 under total internal reflection.
SSS_FN float fresnel_dielectric(float cos_i, float eta, SSS_OUT(float) cos_t) {
    float sin2_t = (1.f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.f) {
        cos_t = 0.f;
        return 1.f;
    }
    cos_t = sqrt(1.f - sin2_t);
    return fresnel_dielectric_cosines(cos_i, cos_t, eta);
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_FRESNEL_H

// Fresnel reflectance of a smooth dielectric interface for unpolarised light. Portable
// (core/portable.h).
#ifndef SSS_SHARED_FRESNEL_H
#define SSS_SHARED_FRESNEL_H

#ifdef __cplusplus
#include "core/portable.h"
namespace sss {
#endif

// cos_i: cosine between the incident travel direction reversed and the normal on the
// incident side (> 0). eta: n_transmitted / n_incident. Returns the reflectance R in [0,
// 1] and sets the transmitted cosine cos_t (> 0); R = 1 under total internal reflection.
SSS_FN float fresnel_dielectric(float cos_i, float eta, SSS_OUT(float) cos_t) {
    float sin2_t = (1.f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.f) {
        cos_t = 0.f;
        return 1.f;
    }
    float ct = sqrt(1.f - sin2_t);
    float r_par = (eta * cos_i - ct) / (eta * cos_i + ct);
    float r_perp = (cos_i - eta * ct) / (cos_i + eta * ct);
    cos_t = ct;
    return 0.5f * (r_par * r_par + r_perp * r_perp);
}

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_FRESNEL_H

// Fresnel reflectance of a smooth dielectric interface for unpolarised light.
#pragma once

#include <cmath>

namespace sss {

// cos_i: cosine between the incident travel direction reversed and the normal on the
// incident side (> 0). eta: n_transmitted / n_incident. Returns the reflectance R in [0,
// 1] and writes the transmitted cosine (> 0); R = 1 under total internal reflection.
inline float fresnel_dielectric(float cos_i, float eta, float* cos_t) {
    float sin2_t = (1.f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.f) {
        *cos_t = 0.f;
        return 1.f;
    }
    float ct = std::sqrt(1.f - sin2_t);
    float r_par = (eta * cos_i - ct) / (eta * cos_i + ct);
    float r_perp = (cos_i - eta * ct) / (cos_i + eta * ct);
    *cos_t = ct;
    return 0.5f * (r_par * r_par + r_perp * r_perp);
}

}  // namespace sss

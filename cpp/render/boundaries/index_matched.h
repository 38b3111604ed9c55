// Index-matched boundary: the medium's index of refraction is the outside's, so a photon
// crosses it unchanged and shadow rays pass through it. Default of every shape.
#ifndef SSS_RENDER_BOUNDARIES_INDEX_MATCHED_H
#define SSS_RENDER_BOUNDARIES_INDEX_MATCHED_H

#include "render/boundaries/boundary.h"

#ifdef __cplusplus
namespace sss {
#endif

// d: the photon's direction; n: the boundary's outward unit normal at the hit.
SSS_FN BoundaryEvent index_matched_boundary_cross(BoundaryData b, Vec3 d, Vec3 n,
                                                  SSS_INOUT(RngState) rng) {
    BoundaryEvent e;
    e.d = d;
    e.crossed = true;
    e.specular = false;
    e.weight = 1.f;
    e.pdf = 0.f;
    return e;
}

SSS_FN BoundaryEval index_matched_boundary_eval(BoundaryData b, Vec3 d, Vec3 wo, Vec3 n,
                                                bool delta_light) {
    return no_boundary_eval();
}

// Whether a straight shadow ray may pass through it.
SSS_FN bool index_matched_boundary_passes_shadow_rays(BoundaryData b) { return true; }

// The medium's index of refraction over the outside's: 1.
SSS_FN float index_matched_boundary_index(BoundaryData b) { return 1.f; }

// Which lights its vertices sample: none (it has no vertices: the medium's events do).
SSS_FN int index_matched_boundary_light_sampling(BoundaryData b) {
    return kSamplesNoLights;
}

#ifdef __cplusplus
inline BoundaryKind index_matched_boundary_kind() {
    BoundaryKind k;
    k.name = "index_matched";
    k.parse = [](const json_fields::json&, const json_fields::Field&) {
        return BoundaryData{};
    };
    k.mitsuba = [](const json_fields::json&) {
        return json_fields::json{{"type", "null"}};
    };
    return k;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_BOUNDARIES_INDEX_MATCHED_H

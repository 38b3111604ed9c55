// Every boundary type, in one list: SSS_BOUNDARY_TYPES(X) calls X(name, id) for each,
// `name` being the prefix of the functions its header (render/boundaries/<name>.h)
// defines and `id` its index here (0, index_matched, is every shape's default). Adding a
// type is one header and two lines in this file (its #include and its entry): the
// dispatch below, the scene parser, the GPU bake and the shaders follow from the list
// (docs/extending.md). Portable: the shaders include it too.
#ifndef SSS_RENDER_BOUNDARIES_REGISTRY_H
#define SSS_RENDER_BOUNDARIES_REGISTRY_H

#include "render/boundaries/dielectric.h"
#include "render/boundaries/index_matched.h"

// clang-format off
#define SSS_BOUNDARY_TYPES(X) \
    X(index_matched, 0)       \
    X(dielectric, 1)
// clang-format on

#ifdef __cplusplus
namespace sss {
#endif

// A photon travelling along d meets boundary b, outward normal n.
SSS_FN BoundaryEvent boundary_cross(BoundaryData b, Vec3 d, Vec3 n,
                                    SSS_INOUT(RngState) rng) {
#define SSS_BOUNDARY_CASE(name, type_id) \
    if (b.type == type_id) return name##_boundary_cross(b, d, n, rng);
    SSS_BOUNDARY_TYPES(SSS_BOUNDARY_CASE)
#undef SSS_BOUNDARY_CASE
    return no_boundary_event(d);  // no such type (cannot happen for a parsed scene)
}

// A rough (or regularized smooth) boundary b's BSDF times |cos| and sampling pdf, for a
// photon that arrived along d and leaves along wo (outward normal n) towards a light,
// a point or directional one if delta_light; 0 where boundary_light_sampling is
// kSamplesNoLights.
SSS_FN BoundaryEval boundary_eval(BoundaryData b, Vec3 d, Vec3 wo, Vec3 n,
                                  bool delta_light) {
#define SSS_BOUNDARY_CASE(name, type_id) \
    if (b.type == type_id) return name##_boundary_eval(b, d, wo, n, delta_light);
    SSS_BOUNDARY_TYPES(SSS_BOUNDARY_CASE)
#undef SSS_BOUNDARY_CASE
    return no_boundary_eval();
}

// Which lights a path vertex on boundary b samples through it (boundary_eval):
// kSamplesNoLights, kSamplesAllLights or kSamplesDeltaLights.
SSS_FN int boundary_light_sampling(BoundaryData b) {
#define SSS_BOUNDARY_CASE(name, type_id) \
    if (b.type == type_id) return name##_boundary_light_sampling(b);
    SSS_BOUNDARY_TYPES(SSS_BOUNDARY_CASE)
#undef SSS_BOUNDARY_CASE
    return kSamplesNoLights;
}

// Whether a straight shadow ray may pass through boundary b.
SSS_FN bool boundary_passes_shadow_rays(BoundaryData b) {
#define SSS_BOUNDARY_CASE(name, type_id) \
    if (b.type == type_id) return name##_boundary_passes_shadow_rays(b);
    SSS_BOUNDARY_TYPES(SSS_BOUNDARY_CASE)
#undef SSS_BOUNDARY_CASE
    return false;
}

// The index of refraction of the medium inside boundary b over that of the outside
// (vacuum): a light inside the medium shines with 1 / index^2 of its radiance on the
// scale of the camera's (docs/notation.md, "No η² radiance scaling").
SSS_FN float boundary_index(BoundaryData b) {
#define SSS_BOUNDARY_CASE(name, type_id) \
    if (b.type == type_id) return name##_boundary_index(b);
    SSS_BOUNDARY_TYPES(SSS_BOUNDARY_CASE)
#undef SSS_BOUNDARY_CASE
    return 1.f;
}

#ifdef __cplusplus
// The C++ side of every type, indexed by id.
inline const std::vector<BoundaryKind>& boundary_kinds() {
    static const std::vector<BoundaryKind> kinds = [] {
        std::vector<BoundaryKind> v;
#define SSS_BOUNDARY_ENTRY(name, type_id) \
    v.push_back(name##_boundary_kind());  \
    v.back().id = type_id;                \
    SSS_CHECK(int(v.size()) == type_id + 1); /* ids count from 0 */
        SSS_BOUNDARY_TYPES(SSS_BOUNDARY_ENTRY)
#undef SSS_BOUNDARY_ENTRY
        return v;
    }();
    return kinds;
}

inline const BoundaryKind& boundary_kind(int id) {
    return boundary_kinds().at(size_t(id));
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_BOUNDARIES_REGISTRY_H

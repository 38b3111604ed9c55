// Every phase function type, in one list: SSS_PHASE_TYPES(X) calls X(name, id) for each,
// `name` being the prefix of the functions its header (render/phase/<name>.h) defines and
// `id` its index here (0, hg, is every medium's default). Adding a type is one header and
// two lines in this file (its #include and its entry): the dispatch below, the scene
// parser, the GPU bake and the shaders follow from the list (docs/extending.md).
// Portable: the shaders include it too.
#ifndef SSS_RENDER_PHASE_REGISTRY_H
#define SSS_RENDER_PHASE_REGISTRY_H

#include "render/phase/hg.h"

// clang-format off
#define SSS_PHASE_TYPES(X) \
    X(hg, 0)
// clang-format on

#ifdef __cplusplus
namespace sss {
#endif

// Phase function p's value for the cosine between incident and scattered direction.
SSS_FN float phase_eval(PhaseData p, float cos_theta) {
#define SSS_PHASE_CASE(name, type_id) \
    if (p.type == type_id) return name##_phase_eval(p, cos_theta);
    SSS_PHASE_TYPES(SSS_PHASE_CASE)
#undef SSS_PHASE_CASE
    return 0.f;
}

// A direction scattered by p for a photon travelling along d (density phase_eval).
SSS_FN Vec3 phase_sample(PhaseData p, Vec3 d, float u1, float u2) {
#define SSS_PHASE_CASE(name, type_id) \
    if (p.type == type_id) return name##_phase_sample(p, d, u1, u2);
    SSS_PHASE_TYPES(SSS_PHASE_CASE)
#undef SSS_PHASE_CASE
    return d;
}

#ifdef __cplusplus
// The C++ side of every type, indexed by id.
inline const std::vector<PhaseKind>& phase_kinds() {
    static const std::vector<PhaseKind> kinds = [] {
        std::vector<PhaseKind> v;
#define SSS_PHASE_ENTRY(name, type_id) \
    v.push_back(name##_phase_kind());  \
    v.back().id = type_id;             \
    SSS_CHECK(int(v.size()) == type_id + 1); /* ids count from 0 */
        SSS_PHASE_TYPES(SSS_PHASE_ENTRY)
#undef SSS_PHASE_ENTRY
        return v;
    }();
    return kinds;
}

inline const PhaseKind& phase_kind(int id) { return phase_kinds().at(size_t(id)); }
}  // namespace sss
#endif

#endif  // SSS_RENDER_PHASE_REGISTRY_H

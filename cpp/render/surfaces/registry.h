// Every opaque surface type, in one list: SSS_SURFACE_TYPES(X) calls X(name, id) for
// each, `name` being the prefix of the functions its header (render/surfaces/<name>.h)
// defines and `id` its index here. Adding a type is one header and two lines in this file
// (its #include and its entry): the dispatch below, the scene parser, the GPU bake and
// the shaders follow from the list (docs/extending.md). Portable: the shaders include it
// too.
#ifndef SSS_RENDER_SURFACES_REGISTRY_H
#define SSS_RENDER_SURFACES_REGISTRY_H

#include "render/surfaces/diffuse.h"

// clang-format off
#define SSS_SURFACE_TYPES(X) \
    X(diffuse, 0)
// clang-format on

#ifdef __cplusplus
namespace sss {
#endif

// Surface s's BSDF times |cos wo| and sampling pdf, for light arriving from wi and
// leaving along wo (unit normal n, either side).
SSS_FN SurfaceEval surface_eval(SurfaceData s, Vec3 wi, Vec3 wo, Vec3 n) {
#define SSS_SURFACE_CASE(name, type_id) \
    if (s.type == type_id) return name##_surface_eval(s, wi, wo, n);
    SSS_SURFACE_TYPES(SSS_SURFACE_CASE)
#undef SSS_SURFACE_CASE
    return no_surface_eval();
}

// An outgoing direction for light arriving from wi (uniforms u1, u2).
SSS_FN SurfaceSample surface_sample(SurfaceData s, Vec3 wi, Vec3 n, float u1, float u2) {
#define SSS_SURFACE_CASE(name, type_id) \
    if (s.type == type_id) return name##_surface_sample(s, wi, n, u1, u2);
    SSS_SURFACE_TYPES(SSS_SURFACE_CASE)
#undef SSS_SURFACE_CASE
    return no_surface_sample(wi);
}

#ifdef __cplusplus
// The C++ side of every type, indexed by id.
inline const std::vector<SurfaceKind>& surface_kinds() {
    static const std::vector<SurfaceKind> kinds = [] {
        std::vector<SurfaceKind> v;
#define SSS_SURFACE_ENTRY(name, type_id) \
    v.push_back(name##_surface_kind());  \
    v.back().id = type_id;               \
    SSS_CHECK(int(v.size()) == type_id + 1); /* ids count from 0 */
        SSS_SURFACE_TYPES(SSS_SURFACE_ENTRY)
#undef SSS_SURFACE_ENTRY
        return v;
    }();
    return kinds;
}

inline const SurfaceKind& surface_kind(int id) { return surface_kinds().at(size_t(id)); }
}  // namespace sss
#endif

#endif  // SSS_RENDER_SURFACES_REGISTRY_H

// Every light type, in one list: SSS_LIGHT_TYPES(X) calls X(name, id) for each, `name`
// being the prefix of the functions its header (render/lights/<name>.h) defines and `id`
// its index here. Adding a type is one header and two lines in this file (its #include
// and its entry): the dispatch below, the scene parser, the GPU bake and the shaders all
// follow from the list (docs/extending.md). Portable: the shaders include it too.
#ifndef SSS_RENDER_LIGHTS_REGISTRY_H
#define SSS_RENDER_LIGHTS_REGISTRY_H

#include "render/lights/area.h"
#include "render/lights/directional.h"
#include "render/lights/environment.h"
#include "render/lights/point.h"

// clang-format off
#define SSS_LIGHT_TYPES(X) \
    X(point, 0)            \
    X(directional, 1)      \
    X(area, 2)             \
    X(environment, 3)
// clang-format on

#ifdef __cplusplus
namespace sss {
#endif

// Samples a direction towards light l from p (uniforms u1, u2). Light types may read the
// scene's table of floats (SSS_LIGHT_FLOAT, light.h): C++ callers pass it last.
SSS_FN LightSample light_sample(LightData l, Vec3 p, float u1,
                                float u2 SSS_LIGHT_FLOATS_PARAM) {
#define SSS_LIGHT_CASE(name, type_id) \
    if (l.type == type_id) return name##_light_sample(l, p, u1, u2 SSS_LIGHT_FLOATS_ARG);
    SSS_LIGHT_TYPES(SSS_LIGHT_CASE)
#undef SSS_LIGHT_CASE
    return no_light_sample();
}

// What a ray from p along w meets on light l at distance t, surface normal n.
SSS_FN LightEval light_eval(LightData l, Vec3 p, Vec3 w, float t,
                            Vec3 n SSS_LIGHT_FLOATS_PARAM) {
#define SSS_LIGHT_CASE(name, type_id) \
    if (l.type == type_id) return name##_light_eval(l, p, w, t, n SSS_LIGHT_FLOATS_ARG);
    SSS_LIGHT_TYPES(SSS_LIGHT_CASE)
#undef SSS_LIGHT_CASE
    return no_light_eval();
}

#ifdef __cplusplus
// The C++ side of every type, indexed by id.
inline const std::vector<LightType>& light_types() {
    static const std::vector<LightType> types = [] {
        std::vector<LightType> v;
#define SSS_LIGHT_ENTRY(name, type_id) \
    v.push_back(name##_light_type());  \
    v.back().id = type_id;             \
    SSS_CHECK(int(v.size()) == type_id + 1); /* ids count from 0 */
        SSS_LIGHT_TYPES(SSS_LIGHT_ENTRY)
#undef SSS_LIGHT_ENTRY
        return v;
    }();
    return types;
}

inline const LightType& light_type(int id) { return light_types().at(size_t(id)); }
}  // namespace sss
#endif

#endif  // SSS_RENDER_LIGHTS_REGISTRY_H

// What every opaque surface type (a shape with "surface" instead of "medium") provides,
// in the common subset of C++ and GLSL (core/portable.h) so that the CPU integrators and
// the shaders reflect light with the same code, and, on the C++ side only, how the type
// reads itself from a scene file and writes itself for Mitsuba 3. One header per type in
// this folder, listed in registry.h; docs/extending.md says how to add one.
//
// Directions point away from the surface point: wi towards where the photon came from
// (-d for a photon travelling along d), wo where it leaves. n is the triangle's unit
// normal, on either side: the integrators do not orient open meshes.
#ifndef SSS_RENDER_SURFACES_SURFACE_H
#define SSS_RENDER_SURFACES_SURFACE_H

#ifdef __cplusplus
#include <functional>
#include <vector>

#include "core/portable.h"
#include "core/vec.h"
#include "render/scene_fields.h"
namespace sss {
#endif

// A surface as the integrators see it: its type (an id of registry.h), a colour and a
// number whose meaning each type states. On the GPU: GpuShape.surface and
// GpuShape.surface_color (gpu/shaders/layout.h).
struct SurfaceData {
    int type;
    Vec3 color;
    float x;
};

// The BSDF times |cos| between wo and the normal (f), and the density with which
// sampling would have chosen wo (pdf, solid angle).
struct SurfaceEval {
    Vec3 f;
    float pdf;
};

// A sampled outgoing direction wo, its weight f / pdf and its pdf (0: no sample; the
// path ends).
struct SurfaceSample {
    Vec3 wo;
    Vec3 weight;
    float pdf;
};

SSS_FN SurfaceEval no_surface_eval() {
    SurfaceEval e;
    e.f = Vec3(0.f, 0.f, 0.f);
    e.pdf = 0.f;
    return e;
}

SSS_FN SurfaceSample no_surface_sample(Vec3 wi) {
    SurfaceSample s;
    s.wo = wi;
    s.weight = Vec3(0.f, 0.f, 0.f);
    s.pdf = 0.f;
    return s;
}

#ifdef __cplusplus
// The C++ side of a surface type.
struct SurfaceKind {
    const char* name = "";  // the scene file's "type"
    int id = -1;            // its entry in SSS_SURFACE_TYPES
    // The keys it takes besides "type", all optional (defaults in `parse`).
    std::vector<const char*> keys;
    // Reads a surface of this type from the scene file's object `j` (at field f); the
    // keys are checked before. Errors name the field, the value and what is allowed.
    std::function<SurfaceData(const json_fields::json& j, const json_fields::Field& f)>
        parse;
    // The shape's BSDF as an entry of Mitsuba 3's load_dict, from the scene file's object
    // (colours {"$rgb": [r, g, b]}, as the lights').
    std::function<json_fields::json(const json_fields::json& j)> mitsuba;
};
#endif

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_RENDER_SURFACES_SURFACE_H

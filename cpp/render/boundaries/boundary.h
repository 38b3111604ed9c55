// What every boundary type (the interface between a shape's medium and the outside)
// provides, in the common subset of C++ and GLSL (core/portable.h) so that the CPU
// integrators and the shaders cross boundaries with the same code, and, on the C++ side
// only, how the type reads itself from a scene file and writes itself for Mitsuba 3. One
// header per type in this folder, listed in registry.h; docs/extending.md says how to add
// one.
#ifndef SSS_RENDER_BOUNDARIES_BOUNDARY_H
#define SSS_RENDER_BOUNDARIES_BOUNDARY_H

#ifdef __cplusplus
#include <functional>
#include <vector>

#include "core/portable.h"
#include "core/rng.h"
#include "core/vec.h"
#include "render/scene_fields.h"
namespace sss {
#endif

// A boundary as the integrators see it: its type (an id of registry.h) and three numbers
// whose meaning each type states. On the GPU: GpuShape.boundary (gpu/shaders/layout.h).
struct BoundaryData {
    int type;
    float x;
    float y;
    float z;
};

// Which lights a path vertex on a boundary samples (boundary_light_sampling): none, all
// of them, or only the point and directional ones (whose light no sampled direction can
// reach, so that their NEE needs no MIS partner).
const int kSamplesNoLights = 0;
const int kSamplesAllLights = 1;
const int kSamplesDeltaLights = 2;

// What a boundary did to a photon that met it: the photon's new direction d, whether it
// crossed to the other side (else it stays on its side), the factor its throughput takes
// (weight: 1 for a smooth interface, the sampled lobe's value / pdf for a rough one; 0
// ends the path), and how d was chosen. specular: by a delta distribution (a smooth
// interface), which gives the next emitter it hits MIS weight 1 (PathState::specular);
// an interface that leaves the direction alone says false and the path keeps what its
// last scattering event set. pdf > 0: sampled from a lobe with that density (solid
// angle); the meeting point is then a path vertex whose light sampling (boundary_eval)
// shares MIS with the emitter d hits.
struct BoundaryEvent {
    Vec3 d;
    bool crossed;
    bool specular;
    float weight;
    float pdf;
};

// A rough boundary's scattering from wi to wo (both pointing away from the surface):
// the BSDF times |cos| between wo and the normal (f; the radiance scaling by the squared
// ratio of indices is left out, docs/notation.md), and the density with which sampling
// would have chosen wo (pdf).
struct BoundaryEval {
    float f;
    float pdf;
};

// No event: the photon is absorbed (weight 0 ends the path).
SSS_FN BoundaryEvent no_boundary_event(Vec3 d) {
    BoundaryEvent e;
    e.d = d;
    e.crossed = false;
    e.specular = false;
    e.weight = 0.f;
    e.pdf = 0.f;
    return e;
}

SSS_FN BoundaryEval no_boundary_eval() {
    BoundaryEval e;
    e.f = 0.f;
    e.pdf = 0.f;
    return e;
}

#ifdef __cplusplus
// The C++ side of a boundary type.
struct BoundaryKind {
    const char* name = "";  // the scene file's "type"
    int id = -1;            // its entry in SSS_BOUNDARY_TYPES
    // The keys it takes besides "type", all optional (defaults in `parse`).
    std::vector<const char*> keys;
    // Reads a boundary of this type from the scene file's object `j` (at field f); the
    // keys are checked before. Errors name the field, the value and what is allowed.
    std::function<BoundaryData(const json_fields::json& j, const json_fields::Field& f)>
        parse;
    // The shape's BSDF as an entry of Mitsuba 3's load_dict, from the scene file's object
    // (or {"type": name} when the shape sets none).
    std::function<json_fields::json(const json_fields::json& j)> mitsuba;
};
#endif

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_RENDER_BOUNDARIES_BOUNDARY_H

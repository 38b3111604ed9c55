// What every phase function type provides, in the common subset of C++ and GLSL
// (core/portable.h) so that the CPU integrators and the shaders scatter with the same
// code, and, on the C++ side only, how the type reads itself from a scene file and writes
// itself for Mitsuba 3. One header per type in this folder, listed in registry.h;
// docs/extending.md says how to add one.
//
// A phase function is sampled exactly: the sampled direction's density is the phase
// function's value, so a scattering event multiplies the throughput by the albedo alone.
#ifndef SSS_RENDER_PHASE_PHASE_H
#define SSS_RENDER_PHASE_PHASE_H

#ifdef __cplusplus
#include <functional>
#include <vector>

#include "core/portable.h"
#include "core/vec.h"
#include "render/scene_fields.h"
namespace sss {
#endif

// A phase function as the integrators see it: its type (an id of registry.h) and two
// numbers whose meaning each type states. On the GPU: GpuShape.phase
// (gpu/shaders/layout.h).
struct PhaseData {
    int type;
    float x;
    float y;
};

#ifdef __cplusplus
// The C++ side of a phase function type.
struct PhaseKind {
    const char* name = "";  // the scene file's "type"
    int id = -1;            // its entry in SSS_PHASE_TYPES
    // The keys it takes besides "type", all optional (defaults in `parse`).
    std::vector<const char*> keys;
    // Reads a phase function of this type from the scene file's object `j` (at field f);
    // the keys are checked before. Errors name the field, the value and what is allowed.
    std::function<PhaseData(const json_fields::json& j, const json_fields::Field& f)>
        parse;
    // The phase function as Mitsuba 3's load_dict entry, from the scene file's object.
    std::function<json_fields::json(const json_fields::json& j)> mitsuba;
    // The mean cosine of the scattering angle (Henyey-Greenstein's g): what the
    // similarity relation reduces sigma_s by, sigma_s' = (1 - g) sigma_s (the first-hit
    // albedo AOV, render/aovs.h).
    std::function<float(const PhaseData&)> mean_cosine;
    // Whether the sphere step's models take it: they are trained for Henyey-Greenstein
    // phase functions, conditioned on g, which such a type keeps in x.
    bool sphere_steps = false;
};
#endif

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_RENDER_PHASE_PHASE_H

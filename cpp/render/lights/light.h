// What every light type provides, in the common subset of C++ and GLSL (core/portable.h)
// so that the CPU integrators and the shaders sample lights with the same code, and, on
// the C++ side only, how the type reads itself from a scene file and writes itself for
// Mitsuba 3. One header per type in this folder, listed in registry.h; docs/extending.md
// says how to add one.
#ifndef SSS_RENDER_LIGHTS_LIGHT_H
#define SSS_RENDER_LIGHTS_LIGHT_H

#ifdef __cplusplus
#include <functional>
#include <string>
#include <vector>

#include "core/portable.h"
#include "core/vec.h"
#include "render/scene_fields.h"
namespace sss {
#endif

// Light types that need more than LightData (an environment map's texels and sampling
// tables) keep it in the scene's table of floats (SceneDesc::light_floats) at an offset
// they store in their data, and read it with SSS_LIGHT_FLOAT(i). In C++ the table is the
// last parameter of the sampling functions (SSS_LIGHT_FLOATS_PARAM, passed on with
// SSS_LIGHT_FLOATS_ARG); the shaders read it from a buffer (render.glsl defines
// SSS_LIGHT_FLOAT there; shaders that sample no lights read 0).
#ifdef __cplusplus
#define SSS_LIGHT_FLOATS_PARAM , const float* light_floats
#define SSS_LIGHT_FLOATS_ARG , light_floats
#define SSS_LIGHT_FLOAT(i) light_floats[i]
#else
#define SSS_LIGHT_FLOATS_PARAM
#define SSS_LIGHT_FLOATS_ARG
#ifndef SSS_LIGHT_FLOAT
#define SSS_LIGHT_FLOAT(i) 0.0
#endif
#endif

// A light as the integrators see it: its type (an id of registry.h) and up to three
// vectors, a colour and a number, whose meaning each type states. Positions are in the
// render frame. On the GPU it is a GpuLight (gpu/shaders/layout.h): four vec4s.
struct LightData {
    int type;
    Vec3 a;
    Vec3 b;
    Vec3 c;
    Vec3 value;
    float scalar;
};

// Shadow rays end this fraction of the way to a light (pbrt's shadow epsilon): an area
// light's own quad, or a surface a point light stands on, is then not in the way, as
// float rounding would decide (PathTracer::transmittance).
SSS_CONST float kShadowRayEnd = 1.f - 1e-4f;

// A direction sampled towards a light from a point p: the unit direction w, the length of
// the shadow ray that tests it (kInf: to infinity; short of an emitter's own surface),
// the radiance arriving along it (delta lights: the intensity over distance squared, or
// the irradiance) and its solid-angle pdf, 0 for a delta light. L = 0: no sample (p
// behind the light, or on it).
struct LightSample {
    Vec3 w;
    float dist;
    Vec3 L;
    float pdf;
};

// The radiance a ray from p along w meets on the light at distance t (surface normal n;
// t = kInf and n unused for lights at infinity) and the pdf with which sampling the light
// from p would have chosen w. Delta lights: never met (L = 0, pdf = 0).
struct LightEval {
    Vec3 L;
    float pdf;
};

SSS_FN LightSample no_light_sample() {
    LightSample s;
    s.w = Vec3(0.f, 0.f, 1.f);
    s.dist = 0.f;
    s.L = Vec3(0.f, 0.f, 0.f);
    s.pdf = 0.f;
    return s;
}

SSS_FN LightEval no_light_eval() {
    LightEval e;
    e.L = Vec3(0.f, 0.f, 0.f);
    e.pdf = 0.f;
    return e;
}

#ifdef __cplusplus
// What a light type's parser may need besides its JSON object: the render frame's origin
// in the scene file's coordinates (positions are stored relative to it), the directory
// relative file names start from, and the scene's table of floats to append to.
struct LightContext {
    Vec3d frame;
    std::string base_dir = ".";
    std::vector<float>* floats = nullptr;
    std::vector<std::string>* inputs = nullptr;  // the files a light reads are added here
};

// The C++ side of a light type.
struct LightType {
    const char* name = "";  // the scene file's "type"
    int id = -1;            // its entry in SSS_LIGHT_TYPES
    // No path can hit it: only light sampling sees it (point, directional).
    bool delta = false;
    // A one-sided quad a + s b + t c (s, t in [0, 1]) emitting along normalize(b x c),
    // added to the ray tracer so that paths can hit it.
    bool quad = false;
    // Met by every ray that leaves the scene (an environment); at most one per scene.
    bool environment = false;
    // The scene file's key whose position `a` holds, if any (checked against the scene's
    // extent: docs/robustness.md).
    const char* position_key = nullptr;
    // The keys it takes besides "type"; each is required unless listed in `optional`.
    std::vector<const char*> keys, optional;
    // Reads a light of this type from the scene file's object `j` (at field f); positions
    // are moved into the render frame (LightContext). The keys are checked before. Errors
    // name the field, the value and what is allowed.
    std::function<LightData(const json_fields::json& j, const json_fields::Field& f,
                            const LightContext& ctx)>
        parse;
    // The same light as an entry of Mitsuba 3's load_dict, from the scene file's object
    // (file coordinates; relative file names are resolved by the caller). Colours are
    // {"$rgb": [r, g, b]} (unbounded sRGB) and transforms
    // {"$matrix": 4x4 rows}: sssphere/mitsuba.py turns them into Mitsuba's types.
    std::function<json_fields::json(const json_fields::json& j)> mitsuba;
};

// The helpers the types' parse and mitsuba functions share.
namespace light_fields {
using json_fields::json;
inline Vec3 radiometric(const json& j, const json_fields::Field& f, const char* key) {
    return json_fields::rgb_in(json_fields::require(j, key, f), f.at(key), 0.0, 1e30,
                               "each channel in [0, 1e30]");
}
inline json mitsuba_rgb(const json& v) {
    return json{{"$rgb", v.is_number() ? json::array({v, v, v}) : v}};
}
}  // namespace light_fields
#endif

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_RENDER_LIGHTS_LIGHT_H

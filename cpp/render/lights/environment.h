// Environment: constant radiance `value` from every direction, met by every ray that
// leaves the scene. Light sampling picks a direction uniformly on the sphere.
#ifndef SSS_RENDER_LIGHTS_ENVIRONMENT_H
#define SSS_RENDER_LIGHTS_ENVIRONMENT_H

#include "render/lights/light.h"
#include "shared/sampling.h"

#ifdef __cplusplus
namespace sss {
#endif

SSS_FN LightSample environment_light_sample(LightData l, Vec3 p, float u1, float u2) {
    LightSample s = no_light_sample();
    s.w = sample_uniform_sphere(u1, u2);
    s.dist = kInf;
    s.L = l.value;
    s.pdf = uniform_sphere_pdf();
    return s;
}

SSS_FN LightEval environment_light_eval(LightData l, Vec3 p, Vec3 w, float t, Vec3 n) {
    LightEval e;
    e.L = l.value;
    e.pdf = uniform_sphere_pdf();
    return e;
}

#ifdef __cplusplus
inline LightType environment_light_type() {
    LightType t;
    t.name = "environment";
    t.environment = true;
    t.keys = {"radiance"};
    t.parse = [](const json_fields::json& j, const json_fields::Field& f, Vec3d) {
        LightData l{};
        l.value = light_fields::radiometric(j, f, "radiance");
        return l;
    };
    t.mitsuba = [](const json_fields::json& j) {
        return json_fields::json{{"type", "constant"},
                                 {"radiance", light_fields::mitsuba_rgb(j["radiance"])}};
    };
    return t;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_LIGHTS_ENVIRONMENT_H

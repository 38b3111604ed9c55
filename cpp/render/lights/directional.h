// Directional light (the sun): a = the unit direction its light travels in, value = the
// irradiance (W/m^2 per channel) on a surface facing it. A delta light: only light
// sampling sees it.
#ifndef SSS_RENDER_LIGHTS_DIRECTIONAL_H
#define SSS_RENDER_LIGHTS_DIRECTIONAL_H

#include "render/lights/light.h"

#ifdef __cplusplus
namespace sss {
#endif

SSS_FN LightSample directional_light_sample(LightData l, Vec3 p, float u1,
                                            float u2 SSS_LIGHT_FLOATS_PARAM) {
    LightSample s = no_light_sample();
    s.w = -l.a;
    s.dist = kInf;
    s.L = l.value;
    return s;
}

SSS_FN LightEval directional_light_eval(LightData l, Vec3 p, Vec3 w, float t,
                                        Vec3 n SSS_LIGHT_FLOATS_PARAM) {
    return no_light_eval();
}

#ifdef __cplusplus
inline LightType directional_light_type() {
    using namespace json_fields;
    LightType t;
    t.name = "directional";
    t.delta = true;
    t.keys = {"direction", "irradiance"};
    t.parse = [](const json& j, const Field& f, const LightContext&) {
        LightData l{};
        l.a = unit_normal(nonzero_vec3(require(j, "direction", f), f.at("direction")));
        l.value = light_fields::radiometric(j, f, "irradiance");
        return l;
    };
    t.mitsuba = [](const json& j) {
        return json{{"type", "directional"},
                    {"direction", j["direction"]},
                    {"irradiance", light_fields::mitsuba_rgb(j["irradiance"])}};
    };
    return t;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_LIGHTS_DIRECTIONAL_H

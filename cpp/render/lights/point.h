// Point light: a = its position, value = its intensity (W/sr per channel). A delta light:
// only light sampling sees it.
#ifndef SSS_RENDER_LIGHTS_POINT_H
#define SSS_RENDER_LIGHTS_POINT_H

#include "render/lights/light.h"

#ifdef __cplusplus
namespace sss {
#endif

SSS_FN LightSample point_light_sample(LightData l, Vec3 p, float u1,
                                      float u2 SSS_LIGHT_FLOATS_PARAM) {
    LightSample s = no_light_sample();
    Vec3 to = l.a - p;
    float dist = length(to);
    if (!(dist > 0.f)) return s;
    s.w = to / dist;
    s.dist = dist;
    s.L = l.value / (dist * dist);
    return s;
}

SSS_FN LightEval point_light_eval(LightData l, Vec3 p, Vec3 w, float t,
                                  Vec3 n SSS_LIGHT_FLOATS_PARAM) {
    return no_light_eval();
}

#ifdef __cplusplus
inline LightType point_light_type() {
    using namespace json_fields;
    LightType t;
    t.name = "point";
    t.delta = true;
    t.position_key = "position";
    t.keys = {"position", "intensity"};
    t.parse = [](const json& j, const Field& f, const LightContext& ctx) {
        LightData l{};
        l.a =
            (point3(require(j, "position", f), f.at("position")) - ctx.frame).to_float();
        l.value = light_fields::radiometric(j, f, "intensity");
        return l;
    };
    t.mitsuba = [](const json& j) {
        return json{{"type", "point"},
                    {"position", j["position"]},
                    {"intensity", light_fields::mitsuba_rgb(j["intensity"])}};
    };
    return t;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_LIGHTS_POINT_H

// Area light: the one-sided quad a + s b + t c (s, t in [0, 1]) emitting radiance `value`
// along normalize(b x c); scalar = its area. Light sampling picks a point uniformly on
// it; paths hit it (a quad in the ray tracer) and it absorbs them.
#ifndef SSS_RENDER_LIGHTS_AREA_H
#define SSS_RENDER_LIGHTS_AREA_H

#include "render/lights/light.h"
#include "shared/path.h"

#ifdef __cplusplus
namespace sss {
#endif

SSS_FN LightSample area_light_sample(LightData l, Vec3 p, float u1,
                                     float u2 SSS_LIGHT_FLOATS_PARAM) {
    LightSample s = no_light_sample();
    Vec3 q = l.a + l.b * u1 + l.c * u2;
    // The cross product's squared length overflows past an area of 1.8e19 (such a light
    // was never sampled, only hit): then scaled by 1 / area first.
    Vec3 n = cross(l.b, l.c);
    n = dot(n, n) <= kFloatMax ? normalize(n) : normalize(n * (1.f / l.scalar));
    Vec3 to = q - p;
    float dist = length(to);
    if (!(dist > 0.f)) return s;
    Vec3 w = to / dist;
    if (dot(w, n) >= 0.f) return s;  // behind the one-sided emitter
    s.w = w;
    s.dist = dist * kShadowRayEnd;  // short of the quad, which would block the ray
    s.L = l.value;
    s.pdf = area_light_pdf(l.scalar, w, dist, n);
    return s;
}

SSS_FN LightEval area_light_eval(LightData l, Vec3 p, Vec3 w, float t,
                                 Vec3 n SSS_LIGHT_FLOATS_PARAM) {
    LightEval e = no_light_eval();
    if (dot(w, n) >= 0.f) return e;  // its back
    e.L = l.value;
    e.pdf = area_light_pdf(l.scalar, w, t, n);
    return e;
}

#ifdef __cplusplus
// The smallest quad area a scene may give: below it the squares in length(cross(b, c))
// underflow single precision (about 1.2e-38) and the area reads as 0.
constexpr double kMinAreaLightArea = 1e-18;
// The largest: past about 1e37 its power (radiance x area x pi) overflows single
// precision and the light renders black; 1e30 is a quad 1e15 across, far past any scene's
// extent (at most 1e10).
constexpr double kMaxAreaLightArea = 1e30;

inline LightType area_light_type() {
    using namespace json_fields;
    LightType t;
    t.name = "area";
    t.quad = true;
    t.position_key = "corner";
    t.keys = {"corner", "edge1", "edge2", "radiance"};
    t.parse = [](const json& j, const Field& f, const LightContext& ctx) {
        LightData l{};
        l.a = (point3(require(j, "corner", f), f.at("corner")) - ctx.frame).to_float();
        l.b = vec3(require(j, "edge1", f), f.at("edge1"));
        l.c = vec3(require(j, "edge2", f), f.at("edge2"));
        // The area in double, so that the message can tell parallel edges from edges
        // too small for single precision (whose squares underflow in length()).
        const json &e1 = j["edge1"], &e2 = j["edge2"];
        double n[3];
        for (int i = 0; i < 3; ++i) {
            const int a = (i + 1) % 3, b = (i + 2) % 3;
            n[i] = e1[a].get<double>() * e2[b].get<double>() -
                   e1[b].get<double>() * e2[a].get<double>();
        }
        const double area = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(area > 0.0))
            f.error(
                "edge1 and edge2 span no area (allowed: two non-parallel, non-zero "
                "edges)");
        if (area < kMinAreaLightArea)
            f.error("edge1 and edge2 span an area of ", area, " (allowed: at least ",
                    kMinAreaLightArea, ", which single precision resolves)");
        if (area > kMaxAreaLightArea)
            f.error("edge1 and edge2 span an area of ", area, " (allowed: at most ",
                    kMaxAreaLightArea, ", whose power single precision holds)");
        // The edges' products in single precision (the sampler's normal): finite
        const Vec3 normal = cross(l.b, l.c);
        if (!(std::abs(normal.x) <= 3.4e38f && std::abs(normal.y) <= 3.4e38f &&
              std::abs(normal.z) <= 3.4e38f))
            f.error(
                "edge1 x edge2 overflows single precision (allowed: edges whose "
                "products stay below 3.4e38)");
        l.scalar = dot(normal, normal) <= kFloatMax ? length(normal) : float(area);
        l.value = light_fields::radiometric(j, f, "radiance");
        return l;
    };
    // A Mitsuba rectangle ([-1, 1]^2 in z = 0, facing +z) moved onto the quad.
    t.mitsuba = [](const json& j) {
        double c[3], e1[3], e2[3];
        for (int i = 0; i < 3; ++i) {
            c[i] = j["corner"][i].get<double>();
            e1[i] = j["edge1"][i].get<double>();
            e2[i] = j["edge2"][i].get<double>();
        }
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        json m = json::array();
        for (int r = 0; r < 3; ++r)
            m.push_back(
                {0.5 * e1[r], 0.5 * e2[r], n[r] / len, c[r] + 0.5 * (e1[r] + e2[r])});
        m.push_back({0.0, 0.0, 0.0, 1.0});
        return json{
            {"type", "rectangle"},
            {"to_world", {{"$matrix", m}}},
            {"bsdf", {{"type", "diffuse"}, {"reflectance", {{"$rgb", {0, 0, 0}}}}}},
            {"emitter",
             {{"type", "area"}, {"radiance", light_fields::mitsuba_rgb(j["radiance"])}}}};
    };
    return t;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_LIGHTS_AREA_H

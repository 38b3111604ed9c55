// Henyey-Greenstein phase function: x = g, the mean cosine, in (-1, 1) (default 0,
// isotropic). The scene file writes it {"type": "hg", "g": 0.3}, or as the medium's "g".
// The sphere step's models are trained for it.
#ifndef SSS_RENDER_PHASE_HG_H
#define SSS_RENDER_PHASE_HG_H

#include "render/phase/phase.h"
#include "shared/hg.h"

#ifdef __cplusplus
namespace sss {
#endif

// The phase function's value (= the density of hg_phase_sample) for the cosine between
// the incident and the scattered direction.
SSS_FN float hg_phase_eval(PhaseData p, float cos_theta) {
    return hg_eval(cos_theta, p.x);
}

// A scattered direction for a photon travelling along d.
SSS_FN Vec3 hg_phase_sample(PhaseData p, Vec3 d, float u1, float u2) {
    return hg_sample(d, p.x, u1, u2);
}

#ifdef __cplusplus
inline PhaseKind hg_phase_kind() {
    using namespace json_fields;
    PhaseKind k;
    k.name = "hg";
    k.keys = {"g"};
    k.sphere_steps = true;
    k.parse = [](const json& j, const Field& f) {
        PhaseData p{};
        if (j.contains("g")) {
            p.x = float(number(j["g"], f.at("g")));
            if (!(std::abs(p.x) < 1.f))
                f.at("g").error("value ", show(j["g"]),
                                " is not allowed (allowed: -1 < g < 1)");
        }
        return p;
    };
    k.mean_cosine = [](const PhaseData& p) { return p.x; };
    k.mitsuba = [](const json& j) {
        return json{{"type", "hg"}, {"g", j.value("g", 0.0)}};
    };
    return k;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_PHASE_HG_H

// The extension points' registries (render/lights/, render/boundaries/, render/phase/):
// every registered type parses from an example, translates for Mitsuba, and keeps the
// contract the integrators rely on (light sampling consistent with evaluation, pdfs that
// integrate to 1, boundaries that obey Fresnel and Snell, phase functions sampled
// exactly). A type added to a registry without an example here fails the first test.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

#include "core/rng.h"
#include "render/scene.h"
#include "shared/sampling.h"

namespace sss {
namespace {

using json = nlohmann::json;

// One scene-file object per registered type.
const std::map<std::string, std::string> kLightExamples = {
    {"point", R"({"type": "point", "position": [0.5, 2, -1], "intensity": [1, 2, 3]})"},
    {"directional",
     R"({"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": 2})"},
    {"area",
     R"({"type": "area", "corner": [-0.5, 1.5, -0.25], "edge1": [1, 0, 0],
         "edge2": [0.2, 0.1, 0.8], "radiance": [4, 3, 2]})"},
    {"environment", R"({"type": "environment", "radiance": [0.5, 0.25, 1]})"},
};
const std::map<std::string, std::string> kBoundaryExamples = {
    {"index_matched", R"({"type": "index_matched"})"},
    {"dielectric", R"({"type": "dielectric", "ior": 1.33})"},
};
const std::map<std::string, std::string> kPhaseExamples = {
    {"hg", R"({"phase": {"type": "hg", "g": 0.6}})"},
};

TEST(Registries, EveryTypeHasAnExampleAndAMitsubaTranslation) {
    for (size_t i = 0; i < light_types().size(); ++i) {
        const LightType& t = light_types()[i];
        EXPECT_EQ(t.id, int(i));
        ASSERT_TRUE(kLightExamples.count(t.name)) << "no example for light " << t.name;
        const Light l = parse_light(kLightExamples.at(t.name));
        EXPECT_EQ(l.type, t.id);
        EXPECT_TRUE(t.mitsuba(json::parse(kLightExamples.at(t.name))).contains("type"));
    }
    for (size_t i = 0; i < boundary_kinds().size(); ++i) {
        const BoundaryKind& k = boundary_kinds()[i];
        EXPECT_EQ(k.id, int(i));
        ASSERT_TRUE(kBoundaryExamples.count(k.name))
            << "no example for boundary " << k.name;
        EXPECT_EQ(parse_boundary(kBoundaryExamples.at(k.name)).type, k.id);
        EXPECT_TRUE(
            k.mitsuba(json::parse(kBoundaryExamples.at(k.name))).contains("type"));
    }
    for (size_t i = 0; i < phase_kinds().size(); ++i) {
        const PhaseKind& k = phase_kinds()[i];
        EXPECT_EQ(k.id, int(i));
        ASSERT_TRUE(kPhaseExamples.count(k.name)) << "no example for phase " << k.name;
        EXPECT_EQ(parse_phase(kPhaseExamples.at(k.name)).type, k.id);
        const json j = json::parse(kPhaseExamples.at(k.name))["phase"];
        EXPECT_TRUE(k.mitsuba(j).contains("type"));
    }
    // Defaults: index-matched, Henyey-Greenstein with g = 0.
    EXPECT_STREQ(Boundary().kind().name, "index_matched");
    EXPECT_STREQ(Phase().kind().name, "hg");
    EXPECT_EQ(Phase().x, 0.f);
}

TEST(Registries, PhaseShorthandAndErrors) {
    EXPECT_EQ(parse_phase(R"({"g": 0.6})").x, parse_phase(kPhaseExamples.at("hg")).x);
    auto error_of = [](const char* text) {
        try {
            parse_phase(text, "m.json");
        } catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_NE(error_of(R"({"g": 0.1, "phase": {"type": "hg"}})").find("either g"),
              std::string::npos);
    EXPECT_NE(error_of(R"({"phase": {"type": "rayleigh"}})").find("allowed: \"hg\""),
              std::string::npos);
    EXPECT_NE(error_of(R"({"phase": {"type": "hg", "g": 1}})").find("-1 < g < 1"),
              std::string::npos);
    EXPECT_NE(error_of(R"({"phase": {"type": "hg", "k": 1}})").find("unknown key 'k'"),
              std::string::npos);
}

// Where a ray from p along w meets light l, if it can: the distance and the normal.
bool meet(const Light& l, Vec3 p, Vec3 w, float& t, Vec3& n) {
    if (l.kind().environment) {
        t = kInf;
        n = Vec3(0.f);
        return true;
    }
    if (!l.kind().quad) return false;
    n = normalize(cross(l.b, l.c));
    const float denom = dot(w, n);
    if (denom == 0.f) return false;
    t = dot(l.a - p, n) / denom;
    if (!(t > 0.f)) return false;
    // The hit's coordinates in the quad's (non-orthogonal) edges.
    const Vec3 q = p + w * t - l.a;
    const float bb = dot(l.b, l.b), bc = dot(l.b, l.c), cc = dot(l.c, l.c);
    const float qb = dot(q, l.b), qc = dot(q, l.c), det = bb * cc - bc * bc;
    const float s = (qb * cc - qc * bc) / det, u = (qc * bb - qb * bc) / det;
    return s >= 0.f && s <= 1.f && u >= 0.f && u <= 1.f;
}

// For lights that paths can meet: a sampled direction, evaluated, gives back the sample's
// radiance and pdf; and the pdf integrates to 1 over the sphere of directions (estimated
// with uniform directions: mean of 4 pi pdf within 4 standard errors of 1).
TEST(Registries, LightSamplingAgreesWithEvaluation) {
    const Vec3 p(0.1f, -0.2f, 0.05f);
    for (const auto& [name, text] : kLightExamples) {
        const Light l = parse_light(text);
        Rng rng(11, l.type);
        int valid = 0;
        for (int i = 0; i < 2000; ++i) {
            const float u1 = rng.uniform(), u2 = rng.uniform();
            const LightSample s = light_sample(l, p, u1, u2);
            if (is_black(s.L)) continue;
            ++valid;
            EXPECT_NEAR(length(s.w), 1.f, 1e-5f) << name;
            if (l.is_delta()) {
                EXPECT_EQ(s.pdf, 0.f) << name;
                continue;
            }
            float t;
            Vec3 n;
            ASSERT_TRUE(meet(l, p, s.w, t, n)) << name;
            const LightEval e = light_eval(l, p, s.w, t, n);
            EXPECT_NEAR(e.pdf, s.pdf, 1e-3f * s.pdf) << name;
            EXPECT_EQ(e.L.x, s.L.x) << name;
            if (std::isfinite(t)) {
                EXPECT_LT(s.dist, t) << name << ": reaches its own surface";
            }
        }
        EXPECT_GT(valid, 1000) << name;
        if (l.is_delta()) continue;
        double sum = 0, sum2 = 0;
        const int n_dirs = 200000;
        for (int i = 0; i < n_dirs; ++i) {
            const Vec3 w = sample_uniform_sphere(rng.uniform(), rng.uniform());
            float t;
            Vec3 n;
            double v = 0;
            if (meet(l, p, w, t, n))
                v = light_eval(l, p, w, t, n).pdf / uniform_sphere_pdf();
            sum += v;
            sum2 += v * v;
        }
        const double mean = sum / n_dirs,
                     se = std::sqrt((sum2 / n_dirs - mean * mean) / n_dirs);
        EXPECT_NEAR(mean, 1.0, 4 * se + 1e-6) << name;
    }
}

// Index-matched: through, unchanged. Dielectric: unit directions; reflection by the
// mirror law with the Fresnel reflectance as frequency (within 4 standard errors), the
// rest refracted by Snell's law; from inside beyond the critical angle always reflected.
TEST(Registries, BoundariesObeyFresnelAndSnell) {
    const Vec3 n(0.f, 0.f, 1.f);  // outward
    RngState rng = rng_make(5, 6, 7);
    const Boundary im = parse_boundary(kBoundaryExamples.at("index_matched"));
    const Vec3 d = normalize(Vec3(0.3f, 0.1f, -1.f));
    const BoundaryEvent e = boundary_cross(im, d, n, rng);
    EXPECT_TRUE(e.crossed);
    EXPECT_FALSE(e.specular);
    EXPECT_EQ(e.d.x, d.x);
    EXPECT_TRUE(im.passes_shadow_rays());

    const Boundary di = parse_boundary(kBoundaryExamples.at("dielectric"));
    EXPECT_FALSE(di.passes_shadow_rays());
    const float eta = di.x;
    for (bool entering : {true, false}) {
        const float cos_i = 0.8f;
        const Vec3 din = normalize(
            Vec3(std::sqrt(1.f - cos_i * cos_i), 0.f, entering ? -cos_i : cos_i));
        float cos_t;
        const float F = fresnel_dielectric(cos_i, entering ? eta : 1.f / eta, cos_t);
        const int trials = 20000;
        int reflected = 0;
        for (int i = 0; i < trials; ++i) {
            const BoundaryEvent b = boundary_cross(di, din, n, rng);
            EXPECT_TRUE(b.specular);
            EXPECT_NEAR(length(b.d), 1.f, 1e-5f);
            if (!b.crossed) {
                ++reflected;
                EXPECT_NEAR(b.d.z, -din.z, 1e-6f);
                EXPECT_NEAR(b.d.x, din.x, 1e-6f);
            } else {
                const float sin_i = din.x, sin_t = b.d.x;
                EXPECT_NEAR(sin_i * (entering ? 1.f : eta),
                            sin_t * (entering ? eta : 1.f), 1e-5f);
                EXPECT_EQ(b.d.z < 0.f, entering);
            }
        }
        const double se = std::sqrt(F * (1.0 - F) / trials);
        EXPECT_NEAR(double(reflected) / trials, F, 4 * se) << "entering " << entering;
    }
    const Vec3 grazing =
        normalize(Vec3(0.9f, 0.f, 0.2f));  // from inside, beyond critical
    for (int i = 0; i < 100; ++i)
        EXPECT_FALSE(boundary_cross(di, grazing, n, rng).crossed);
}

// Phase functions are sampled exactly: the mean cosine of sampled directions equals the
// phase function's (estimated with uniform directions), and its value integrates to 1;
// both within 4 standard errors.
TEST(Registries, PhaseFunctionsAreSampledExactly) {
    for (const auto& [name, text] : kPhaseExamples) {
        const Phase p = parse_phase(text);
        Rng rng(3, p.type);
        const Vec3 d = normalize(Vec3(0.2f, -0.5f, 0.7f));
        const int n = 200000;
        double c_sum = 0, c_sum2 = 0, i_sum = 0, i_sum2 = 0, m_sum = 0, m_sum2 = 0;
        for (int i = 0; i < n; ++i) {
            const float u1 = rng.uniform(), u2 = rng.uniform();
            const double c = dot(d, phase_sample(p, d, u1, u2));
            c_sum += c;
            c_sum2 += c * c;
            const Vec3 w = sample_uniform_sphere(rng.uniform(), rng.uniform());
            const double v = phase_eval(p, dot(d, w)) / uniform_sphere_pdf();
            i_sum += v;
            i_sum2 += v * v;
            m_sum += v * dot(d, w);
            m_sum2 += v * v * dot(d, w) * dot(d, w);
        }
        auto se = [n](double s, double s2) {
            return std::sqrt((s2 / n - (s / n) * (s / n)) / n);
        };
        EXPECT_NEAR(i_sum / n, 1.0, 4 * se(i_sum, i_sum2)) << name;
        EXPECT_NEAR(c_sum / n, m_sum / n,
                    4 * std::hypot(se(c_sum, c_sum2), se(m_sum, m_sum2)))
            << name;
    }
}

}  // namespace
}  // namespace sss

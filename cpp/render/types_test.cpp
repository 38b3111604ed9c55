// The extension points' registries (render/lights/, render/boundaries/, render/phase/,
// render/surfaces/):
// every registered type parses from an example, translates for Mitsuba, and keeps the
// contract the integrators rely on (light sampling consistent with evaluation, pdfs that
// integrate to 1, boundaries that obey Fresnel and Snell, phase functions sampled
// exactly, surfaces whose sampling matches their BSDF). A type added to a registry
// without an example here fails the first test.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

#include "core/rng.h"
#include "io/image_io.h"
#include "render/scene.h"
#include "shared/sampling.h"
#include "testing/errors.h"

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
// Rough boundaries, for the BSDF's property tests.
const std::vector<std::string> kRoughBoundaries = {
    R"({"type": "dielectric", "ior": 1.5, "roughness": 0.3})",
    R"({"type": "dielectric", "ior": 1.33, "roughness": 0.6})",
    R"({"type": "dielectric", "ior": 0.7, "roughness": 0.4})",
};
const std::map<std::string, std::string> kSurfaceExamples = {
    {"diffuse", R"({"type": "diffuse", "reflectance": [0.8, 0.5, 0.2]})"},
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
    for (size_t i = 0; i < surface_kinds().size(); ++i) {
        const SurfaceKind& k = surface_kinds()[i];
        EXPECT_EQ(k.id, int(i));
        ASSERT_TRUE(kSurfaceExamples.count(k.name))
            << "no example for surface " << k.name;
        EXPECT_EQ(parse_surface(kSurfaceExamples.at(k.name)).type, k.id);
        EXPECT_TRUE(k.mitsuba(json::parse(kSurfaceExamples.at(k.name))).contains("type"));
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
            const LightSample s = light_sample(l, p, u1, u2, nullptr);
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
            const LightEval e = light_eval(l, p, s.w, t, n, nullptr);
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
                v = light_eval(l, p, w, t, n, nullptr).pdf / uniform_sphere_pdf();
            sum += v;
            sum2 += v * v;
        }
        const double mean = sum / n_dirs,
                     se = std::sqrt((sum2 / n_dirs - mean * mean) / n_dirs);
        EXPECT_NEAR(mean, 1.0, 4 * se + 1e-6) << name;
    }
}

// The chi-square value that a chi-square variable with `dof` degrees of freedom exceeds
// with probability 1e-3 (Wilson-Hilferty; within a few per cent for dof >= 10).
double chi2_limit(int dof) {
    const double z = 3.0902, k = 2.0 / (9.0 * dof);
    return dof * std::pow(1.0 - k + z * std::sqrt(k), 3.0);
}

// Directions binned by (cos theta, phi) about a frame's z, 40 x 16 bins of equal solid
// angle, for chi-square tests of direction sampling against a pdf.
constexpr int kCosBins = 40, kPhiBins = 16;

int sphere_bin(const Frame& frame, Vec3 w) {
    const Vec3 l = frame_to_local(frame, w);
    const int c = std::clamp(int((l.z + 1.f) * 0.5f * kCosBins), 0, kCosBins - 1);
    const float phi = std::atan2(l.y, l.x) + float(M_PI);
    const int p = std::clamp(int(phi / (2.f * float(M_PI)) * kPhiBins), 0, kPhiBins - 1);
    return c * kPhiBins + p;
}

// The counts n samples drawn with density pdf(w) (solid angle) put in each sphere_bin:
// the pdf integrated over each bin by the midpoint rule on sub x sub cells.
template <class Pdf>
std::vector<double> expected_bin_counts(const Frame& frame, const Pdf& pdf, int n,
                                        int sub) {
    std::vector<double> expected(kCosBins * kPhiBins, 0.0);
    const double d_omega = (2.0 / kCosBins) * (2.0 * M_PI / kPhiBins) / (sub * sub);
    for (int c = 0; c < kCosBins; ++c)
        for (int p = 0; p < kPhiBins; ++p)
            for (int i = 0; i < sub; ++i)
                for (int j = 0; j < sub; ++j) {
                    const float z = -1.f + 2.f * (c + (i + 0.5f) / sub) / kCosBins;
                    const float phi =
                        2.f * float(M_PI) * (p + (j + 0.5f) / sub) / kPhiBins -
                        float(M_PI);
                    const float r = std::sqrt(std::max(0.f, 1.f - z * z));
                    const Vec3 w = frame_to_world(
                        frame, Vec3(r * std::cos(phi), r * std::sin(phi), z));
                    expected[c * kPhiBins + p] += pdf(w) * d_omega * n;
                }
    return expected;
}

// Pearson's chi-square of observed against expected counts, the bins expecting fewer than
// 5 pooled into one (whose expectation counts as at least 5, so that samples where the
// pdf says almost none still raise it), and its degrees of freedom.
struct ChiSquare {
    double value = 0;
    int dof = -1;
};
ChiSquare chi_square(const std::vector<double>& observed,
                     const std::vector<double>& expected) {
    ChiSquare x;
    double pooled_o = 0, pooled_e = 0;
    for (size_t k = 0; k < expected.size(); ++k) {
        if (expected[k] < 5) {
            pooled_o += observed[k];
            pooled_e += expected[k];
            continue;
        }
        x.value +=
            (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
        ++x.dof;
    }
    x.value += (pooled_o - pooled_e) * (pooled_o - pooled_e) / std::max(pooled_e, 5.0);
    ++x.dof;
    return x;
}

// An environment map with structure in every direction and a small bright spot: written
// as an EXR, read back through the installed reader, as a scene would.
Light environment_map_light(std::vector<float>& floats, const char* extra = "") {
    const int W = 64, H = 32;
    std::vector<float> px(size_t(3) * W * H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            for (int c = 0; c < 3; ++c)
                px[size_t(3) * (y * W + x) + c] =
                    0.2f + 0.1f * c + float(x) / W + 0.5f * float(y % 5 == 0) +
                    (x == 40 && y == 9 ? 400.f : 0.f) + (y > 20 && x < 10 ? 0.f : 0.05f);
    const std::string path = ::testing::TempDir() + "types_test_env.exr";
    write_image(path, px, W, H);
    install_image_reader();
    return parse_light(std::string(R"({"type": "environment", "map": ")") + path +
                           R"(", "scale": 1.5)" + extra + "}",
                       "<env>", Vec3d(), ".", &floats);
}

// An environment map: a sampled direction, evaluated, gives back its radiance and pdf;
// the pdf integrates to 1; light sampling estimates the map's integral (the mean of
// L / pdf over light samples equals that of 4 pi L over uniform directions, within 4
// standard errors of their difference); and the sampled directions fall into the map's
// cells as often as the cells' probabilities say, uniformly within each (a chi-square
// test over 3 x 2 parts of every cell, alpha = 1e-3, parts expecting fewer than 5
// pooled), the seam of the map at u = 0 included.
// A quad's normal past an area of 1.8e19 (its cross product's square overflows float):
// such a light was never sampled (its normal read as 0), only hit; below 1e-18 it is
// refused.
TEST(Registries, HugeAndFarAreaLightsAreSampled) {
    const Light huge = parse_light(
        R"({"type": "area", "corner": [-2.5e14, 2, -2.5e14], "edge1": [5e14, 0, 0],
            "edge2": [0, 0, 5e14], "radiance": 1})");
    const Vec3 p(0.f, 0.f, 0.f);
    const LightSample s = light_sample(huge, p, 0.5f, 0.5f, nullptr);
    EXPECT_FALSE(is_black(s.L));
    EXPECT_NEAR(s.w.y, 1.f, 1e-6f);
    EXPECT_NEAR(s.pdf, 4.f / 2.5e29f, 1e-3f * 4.f / 2.5e29f);  // dist^2 / (area cos)
    EXPECT_EQ(huge.scalar, 2.5e29f);
    EXPECT_HAS(
        test::error_of([] {
            parse_light(R"({"type": "area", "corner": [0, 2, 0], "edge1": [1e20, 1e20, 0],
                                   "edge2": [1e20, 1.0000000000001e20, 0], "radiance": 1})");
        }),
        "edge1 x edge2 overflows single precision");
}

TEST(Registries, EnvironmentMapSamplingAgreesWithEvaluation) {
    for (const char* extra : {"", ", \"rotate_deg\": [20, -70, 10]"}) {
        std::vector<float> floats;
        const Light l = environment_map_light(floats, extra);
        const float* f = floats.data();
        const Vec3 p(0.f);
        Rng rng(21, 1);
        const int n = 400000;
        const int W = int(f[0]), H = int(f[1]);
        constexpr int kSx = 3, kSy = 2;  // parts of a cell along x and y
        std::vector<double> observed(size_t(kSx * kSy) * W * (H - 1), 0.0);
        double s_sum = 0, s_sum2 = 0, u_sum = 0, u_sum2 = 0, pdf_sum = 0, pdf_sum2 = 0;
        for (int i = 0; i < n; ++i) {
            const float u1 = rng.uniform(), u2 = rng.uniform();
            const LightSample s = light_sample(l, p, u1, u2, f);
            if (s.pdf > 0.f) {
                const LightEval e = light_eval(l, p, s.w, kInf, Vec3(0.f), f);
                ASSERT_NEAR(e.pdf, s.pdf, 1e-3f * s.pdf) << extra;
                ASSERT_NEAR(e.L.y, s.L.y, 1e-4f * s.L.y + 1e-6f) << extra;
                const double v = s.L.y / s.pdf;
                s_sum += v;
                s_sum2 += v * v;
                const Vec3 xy = env_map_xy(l, s.w, W, H);
                observed[size_t(std::min(int(kSy * xy.y), kSy * (H - 1) - 1)) * kSx * W +
                         size_t(std::min(int(kSx * xy.x), kSx * W - 1))] += 1;
            }
            const Vec3 w = sample_uniform_sphere(rng.uniform(), rng.uniform());
            const LightEval e = light_eval(l, p, w, kInf, Vec3(0.f), f);
            const double v = e.L.y / uniform_sphere_pdf();
            u_sum += v;
            u_sum2 += v * v;
            const double q = e.pdf / uniform_sphere_pdf();
            pdf_sum += q;
            pdf_sum2 += q * q;
        }
        auto se = [n](double s, double s2) {
            return std::sqrt((s2 / n - (s / n) * (s / n)) / n);
        };
        EXPECT_NEAR(pdf_sum / n, 1.0, 4 * se(pdf_sum, pdf_sum2)) << extra;
        const int m = environment_map::marginal_offset(W, H);
        double chi2 = 0, pooled_o = 0, pooled_e = 0;
        int dof = -1;
        for (int j = 0; j + 1 < H; ++j)
            for (int i = 0; i < W; ++i) {
                const int c = environment_map::conditional_offset(W, H, j);
                const double e = n * double(f[m + j + 1] - f[m + j]) *
                                 double(f[c + i + 1] - f[c + i]) / (kSx * kSy);
                for (int q = 0; q < kSx * kSy; ++q) {
                    const double o = observed[size_t(kSy * j + q / kSx) * kSx * W +
                                              size_t(kSx * i + q % kSx)];
                    if (e < 5) {
                        pooled_o += o;
                        pooled_e += e;
                        continue;
                    }
                    chi2 += (o - e) * (o - e) / e;
                    ++dof;
                }
            }
        if (pooled_e > 0) {
            chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
            ++dof;
        }
        ASSERT_GT(dof, 500);
        EXPECT_LT(chi2, chi2_limit(dof)) << extra;
        EXPECT_NEAR(s_sum / n, u_sum / n,
                    4 * std::hypot(se(s_sum, s_sum2), se(u_sum, u_sum2)))
            << extra << ": light sampling " << s_sum / n << ", uniform " << u_sum / n;
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

// A smooth dielectric's regularization: its vertices sample the point and directional
// lights only, through the rough BSDF of alpha = regularization (the same value and pdf
// as that rough boundary's, from both sides), while crossing it stays a delta; with
// regularization 0 they sample nothing. A rough boundary takes the larger of its alpha
// and the regularization for the point and directional lights, its own alpha for the
// rest.
TEST(Registries, RegularizedSmoothDielectricSamplesDeltaLightsThroughARoughLobe) {
    const Boundary smooth = parse_boundary(R"({"type": "dielectric", "ior": 1.4})");
    EXPECT_EQ(boundary_light_sampling(smooth), kSamplesDeltaLights);
    EXPECT_TRUE(smooth.samples_delta_lights_only());
    EXPECT_EQ(smooth.z, kDefaultRegularization);
    const Boundary reg =
        parse_boundary(R"({"type": "dielectric", "ior": 1.4, "regularization": 0.2})");
    const Boundary rough =
        parse_boundary(R"({"type": "dielectric", "ior": 1.4, "roughness": 0.2})");
    const Boundary off =
        parse_boundary(R"({"type": "dielectric", "ior": 1.4, "regularization": 0})");
    const Boundary rough_reg = parse_boundary(
        R"({"type": "dielectric", "ior": 1.4, "roughness": 0.2, "regularization": 0.7})");
    const Boundary reg7 =
        parse_boundary(R"({"type": "dielectric", "ior": 1.4, "regularization": 0.7})");
    const Boundary faint = parse_boundary(
        R"({"type": "dielectric", "ior": 1.4, "roughness": 0.01, "regularization": 0.2})");
    const Boundary faint_only = parse_boundary(
        R"({"type": "dielectric", "ior": 1.4, "roughness": 0.01, "regularization": 0})");
    EXPECT_EQ(boundary_light_sampling(off), kSamplesNoLights);
    EXPECT_EQ(boundary_light_sampling(rough_reg), kSamplesAllLights);
    const Vec3 n = normalize(Vec3(0.2f, -0.1f, 1.f));
    Rng rng(31, 0);
    int nonzero = 0;
    for (int i = 0; i < 2000; ++i) {
        const Vec3 d = sample_uniform_sphere(rng.uniform(), rng.uniform());
        const Vec3 wo = sample_uniform_sphere(rng.uniform(), rng.uniform());
        const BoundaryEval a = boundary_eval(reg, d, wo, n, true),
                           b = boundary_eval(rough, d, wo, n, true);
        EXPECT_EQ(a.f, b.f);
        EXPECT_EQ(a.pdf, b.pdf);
        // a rough boundary's own alpha for the lights it samples with MIS, and for the
        // point and directional ones where it is the larger
        EXPECT_EQ(boundary_eval(rough_reg, d, wo, n, false).f, b.f);
        EXPECT_EQ(boundary_eval(rough, d, wo, n, false).f, b.f);
        EXPECT_EQ(boundary_eval(off, d, wo, n, true).f, 0.f);
        // less rough than its regularization: point and directional lights through the
        // regularization's lobe, as the smooth interface (alpha -> 0) has them
        EXPECT_EQ(boundary_eval(rough_reg, d, wo, n, true).f,
                  boundary_eval(reg7, d, wo, n, true).f);
        EXPECT_EQ(boundary_eval(faint, d, wo, n, true).f, a.f);
        EXPECT_EQ(boundary_eval(faint, d, wo, n, true).pdf, a.pdf);
        EXPECT_EQ(boundary_eval(faint, d, wo, n, false).f,
                  boundary_eval(faint_only, d, wo, n, false).f);
        nonzero += a.f > 0.f;
        RngState s = rng_make(1, uint64_t(i), 0);
        EXPECT_TRUE(boundary_cross(reg, d, n, s).specular);
    }
    EXPECT_GT(nonzero, 500);  // both sides, reflection and transmission
}

// A rough dielectric boundary, for photons arriving from several directions on both
// sides (outward normal n, tilted):
// - sampling follows the BSDF: a chi-square test (alpha = 1e-3) of sampled directions in
//   40 x 16 bins of (cos theta, phi) about the normal against the pdf boundary_eval
//   gives, integrated over each bin (16 x 16 midpoints; bins expecting fewer than 5
//   pooled); samples that fail (masked) are the missing mass;
// - a sample's weight is eval's f / pdf, and its pdf eval's pdf (to float precision:
//   near the critical angle the Fresnel term amplifies rounding);
// - energy: the integral of f (uniform directions) is at most 1, within 4 standard
//   errors;
// - reciprocity with the squared indices: f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2, f
//   being eval's value over |cos wo|: to 1e-3 for 99 % of the directions and 10 % for
//   all (where the refracted ray grazes its micro-facet, at the critical angle, the
//   Fresnel term's derivative is infinite, and float rounding of the inputs shows).
TEST(Registries, RoughDielectricSamplesItsBsdf) {
    const Vec3 n = normalize(Vec3(-0.3f, 0.2f, 0.9f));
    const Frame frame = frame_from_z(n);
    for (const std::string& text : kRoughBoundaries) {
        const Boundary b = parse_boundary(text);
        ASSERT_TRUE(b.samples_lights()) << text;
        RngState rng = rng_make(23, uint64_t(b.x * 100), uint64_t(b.y * 100));
        for (const float cos_d : {-0.9f, -0.35f, 0.8f, 0.3f}) {  // < 0: from outside
            const float sin_d = std::sqrt(1.f - cos_d * cos_d);
            const Vec3 d = frame_to_world(frame, Vec3(sin_d, 0.f, cos_d));
            const std::string what = text + ", cos_d " + std::to_string(cos_d);
            const int n_samples = 200000;
            std::vector<double> observed(kCosBins * kPhiBins, 0.0);
            for (int i = 0; i < n_samples; ++i) {
                const BoundaryEvent e = boundary_cross(b, d, n, rng);
                ASSERT_FALSE(e.specular);
                if (!(e.weight > 0.f)) continue;
                observed[sphere_bin(frame, e.d)] += 1;
                ASSERT_EQ(e.crossed, dot(e.d, n) * dot(d, n) > 0.f) << what;
                const BoundaryEval ev = boundary_eval(b, d, e.d, n, false);
                ASSERT_NEAR(ev.pdf, e.pdf, 1e-3f * e.pdf + 1e-5f) << what;
                ASSERT_NEAR(e.weight, ev.f / ev.pdf, 1e-3f) << what;
                ASSERT_LE(e.weight, 1.f);
            }
            const ChiSquare x = chi_square(
                observed,
                expected_bin_counts(
                    frame, [&](Vec3 w) { return boundary_eval(b, d, w, n, false).pdf; },
                    n_samples, 16));
            ASSERT_GT(x.dof, 30) << what;
            EXPECT_LT(x.value, chi2_limit(x.dof)) << what;

            // Energy and reciprocity.
            const int n_dirs = 200000;
            double sum = 0, sum2 = 0;
            int nonzero = 0, loose = 0;  // reciprocal only to within 1e-3 (see above)
            const float eta_d = dot(d, n) < 0.f ? 1.f : b.x;  // the index on d's side
            for (int i = 0; i < n_dirs; ++i) {
                const Vec3 wo = sample_uniform_sphere(rng_uniform(rng), rng_uniform(rng));
                const BoundaryEval e = boundary_eval(b, d, wo, n, false);
                const double v = e.f / uniform_sphere_pdf();
                sum += v;
                sum2 += v * v;
                if (!(e.f > 0.f)) continue;
                const float eta_o = dot(wo, n) > 0.f ? 1.f : b.x;
                const BoundaryEval back = boundary_eval(b, -wo, -d, n, false);
                const double f = e.f / std::abs(dot(wo, n)) / (eta_o * eta_o),
                             f_back = back.f / std::abs(dot(d, n)) / (eta_d * eta_d);
                ++nonzero;
                if (std::abs(f - f_back) > 1e-3 * f + 1e-5) ++loose;
                EXPECT_NEAR(f, f_back, 0.1 * f + 1e-5) << what;
            }
            EXPECT_LT(loose, nonzero / 100) << what;
            const double mean = sum / n_dirs;
            EXPECT_LE(mean, 1.0 + 4 * std::sqrt((sum2 / n_dirs - mean * mean) / n_dirs))
                << what;
        }
    }
}

// The rough interface's smooth limit: at alpha = 1e-3 a photon is reflected with the
// Fresnel reflectance as frequency (within 4 standard errors), with weight ~1, along the
// mirror or the refracted direction of the smooth interface: GGX has long tails (a
// micro-normal is tilted by more than 0.01 rad with probability alpha^2 / (alpha^2 +
// 0.01^2) ~ 1 %), so at most 3 % of them deviate by more than 0.02 rad.
TEST(Registries, RoughDielectricTendsToTheSmoothOne) {
    const Vec3 n(0.f, 0.f, 1.f);
    const Boundary rough =
        parse_boundary(R"({"type": "dielectric", "ior": 1.5, "roughness": 0.001})");
    const Boundary smooth = parse_boundary(R"({"type": "dielectric", "ior": 1.5})");
    RngState rng = rng_make(29, 30, 31);
    for (const float cos_d : {-0.8f, -0.2f, 0.9f}) {
        const Vec3 d = normalize(Vec3(std::sqrt(1.f - cos_d * cos_d), 0.f, cos_d));
        float cos_t;
        const float F =
            fresnel_dielectric(std::abs(cos_d), cos_d < 0.f ? 1.5f : 1.f / 1.5f, cos_t);
        // The smooth interface's two directions.
        Vec3 mirror(0.f), refracted(0.f);
        for (int i = 0; i < 200; ++i) {
            const BoundaryEvent s = boundary_cross(smooth, d, n, rng);
            (s.crossed ? refracted : mirror) = s.d;
        }
        const int trials = 40000;
        int reflected = 0, off = 0;
        for (int i = 0; i < trials; ++i) {
            const BoundaryEvent e = boundary_cross(rough, d, n, rng);
            ASSERT_GT(e.weight, 0.99f);
            reflected += e.crossed ? 0 : 1;
            const Vec3 want = e.crossed ? refracted : mirror;
            off += std::acos(std::min(1.f, dot(e.d, want))) > 0.02f ? 1 : 0;
        }
        EXPECT_LT(off, trials * 3 / 100) << cos_d;
        const double se = std::sqrt(F * (1.0 - F) / trials);
        EXPECT_NEAR(double(reflected) / trials, F, 4 * se + 1e-6) << cos_d;
    }
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

// Surfaces, for light arriving from several directions on both sides of the normal:
// - sampling follows the BSDF: a chi-square test (alpha = 1e-3) of sampled directions in
//   40 x 16 bins of (cos theta, phi) about the normal against the sample pdf the type's
//   eval gives, integrated over each bin (bins expecting fewer than 5 pooled);
// - a sample's weight is eval's f / pdf, and its pdf eval's pdf;
// - the pdf integrates to 1 and the albedo (the integral of f) is at most 1 per channel,
//   both within 4 standard errors (uniform directions);
// - f / |cos wo| is reciprocal: the same with wi and wo swapped.
TEST(Registries, SurfacesSampleTheirBsdfAndConserveEnergy) {
    const Vec3 n = normalize(Vec3(0.2f, 0.9f, -0.3f));
    const Frame frame = frame_from_z(n);
    for (const auto& [name, text] : kSurfaceExamples) {
        const Surface s = parse_surface(text);
        Rng rng(17, s.type);
        for (const float cos_i : {0.95f, 0.4f, 0.05f, -0.6f}) {
            const float sin_i = std::sqrt(1.f - cos_i * cos_i);
            const Vec3 wi = frame_to_world(frame, Vec3(sin_i, 0.f, cos_i));
            // Sampled counts, with each sample checked against eval.
            const int n_samples = 200000;
            std::vector<double> observed(kCosBins * kPhiBins, 0.0);
            for (int i = 0; i < n_samples; ++i) {
                const float u1 = rng.uniform(), u2 = rng.uniform();
                const SurfaceSample ss = surface_sample(s, wi, n, u1, u2);
                if (!(ss.pdf > 0.f)) continue;
                observed[sphere_bin(frame, ss.wo)] += 1;
                const SurfaceEval e = surface_eval(s, wi, ss.wo, n);
                ASSERT_NEAR(e.pdf, ss.pdf, 1e-4f * ss.pdf) << name;
                for (int c = 0; c < 3; ++c)
                    ASSERT_NEAR(ss.weight[c], e.f[c] / e.pdf, 1e-4f) << name;
            }
            // Expected counts: eval's pdf integrated over each bin (8 x 8 midpoints).
            const ChiSquare x = chi_square(
                observed,
                expected_bin_counts(
                    frame, [&](Vec3 w) { return surface_eval(s, wi, w, n).pdf; },
                    n_samples, 8));
            ASSERT_GT(x.dof, 50) << name;
            EXPECT_LT(x.value, chi2_limit(x.dof)) << name << ", cos_i " << cos_i;

            // The pdf integrates to 1, the albedo to at most 1; reciprocity.
            const int n_dirs = 200000;
            double sum = 0, sum2 = 0;
            Vec3 albedo(0.f), albedo2(0.f);
            for (int i = 0; i < n_dirs; ++i) {
                const Vec3 wo = sample_uniform_sphere(rng.uniform(), rng.uniform());
                const SurfaceEval e = surface_eval(s, wi, wo, n);
                const double v = e.pdf / uniform_sphere_pdf();
                sum += v;
                sum2 += v * v;
                const Vec3 fa = e.f / uniform_sphere_pdf();
                albedo += fa;
                albedo2 += fa * fa;
                const SurfaceEval back = surface_eval(s, wo, wi, n);
                for (int c = 0; c < 3; ++c)
                    EXPECT_NEAR(e.f[c] * std::abs(dot(wi, n)),
                                back.f[c] * std::abs(dot(wo, n)), 1e-5f)
                        << name;
            }
            const double mean = sum / n_dirs;
            EXPECT_NEAR(mean, 1.0, 4 * std::sqrt((sum2 / n_dirs - mean * mean) / n_dirs))
                << name;
            for (int c = 0; c < 3; ++c) {
                const double a = albedo[c] / n_dirs;
                const double se = std::sqrt((albedo2[c] / n_dirs - a * a) / n_dirs);
                EXPECT_LE(a, 1.0 + 4 * se) << name << " channel " << c;
            }
        }
    }
}

// The diffuse surface reflects exactly its reflectance (its albedo), on either side.
TEST(Registries, DiffuseSurfaceReflectsItsReflectance) {
    const Surface s = parse_surface(kSurfaceExamples.at("diffuse"));
    const Vec3 n(0.f, 0.f, 1.f);
    for (const float z : {0.7f, -0.7f}) {
        const Vec3 wi = normalize(Vec3(0.3f, 0.2f, z));
        const SurfaceSample ss = surface_sample(s, wi, n, 0.3f, 0.6f);
        EXPECT_GT(ss.wo.z * z, 0.f);  // on wi's side
        EXPECT_EQ(ss.weight.x, s.color.x);
        EXPECT_EQ(ss.weight.z, s.color.z);
        EXPECT_EQ(surface_eval(s, wi, Vec3(0.f, 0.f, -z), n).pdf, 0.f);  // through it
    }
}

}  // namespace
}  // namespace sss

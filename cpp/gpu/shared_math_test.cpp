// The portable maths (core/frame.h, cpp/shared/) on the GPU against the same source
// compiled as C++. The text is one, so what can differ is what each side supplies:
// portable.glsl's log1p, expm1 and copysign, the GPU's exp, log, sin and cos, and float
// where the CPU computes in double. Tolerances come from the precision Vulkan requires of
// a device (Vulkan spec, "Precision and Operation of SPIR-V Instructions": exp 3 + 2|x|
// ULP; log 3 ULP, or 2^-21 absolute for arguments in [0.5, 2]; sin and cos 2^-11
// absolute), times how much each formula amplifies its inputs' errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/frame.h"
#include "gpu/vulkan_compute.h"
#include "shared/fresnel.h"
#include "shared/hg.h"
#include "shared/sampling.h"
#include "shared/softplus.h"
#include "shared/sphere_step.h"

namespace sss {
namespace {

static const uint32_t kTestSharedMath[] =
#include "shaders/test_shared_math.spv.h"
    ;

constexpr int kIn = 15, kOut = 24;  // as test_shared_math.comp
constexpr double kEps = 0x1p-24;    // float's unit roundoff
constexpr double kLogAbs = 0x1p-21;
constexpr double kTrigAbs = 0x1p-11;

struct Case {
    float c, g, u1, u2, cos_i, eta, sigma, x, phi, n, alpha, beta;
    float px, py, pz;  // a decoder output to project: 1e-30 to 1e38 long, or about 1
};

// Cases over the functions' domains, with the edges that need care: g near 0 (HG's
// isotropic branch), albedos near 1 (phi = 1 - 10^-k, and 1 exactly), grazing and
// total-internal-reflection Fresnel angles.
std::vector<Case> make_cases(int count) {
    std::mt19937 gen(20261123);
    std::uniform_real_distribution<float> unit(0.f, 1.f);
    auto u24 = [&] { return float(gen() >> 8) * 0x1p-24f; };  // as Rng::uniform
    std::vector<Case> cases;
    for (int i = 0; i < count; ++i) {
        Case k;
        k.c = 2.f * unit(gen) - 1.f;
        k.g = i % 10 == 0 ? (unit(gen) - 0.5f) * 2e-3f : (2.f * unit(gen) - 1.f) * 0.95f;
        k.u1 = u24();
        k.u2 = u24();
        k.cos_i = std::max(unit(gen), 1e-4f);
        k.eta = 0.5f + 1.5f * unit(gen);
        k.sigma = 0.1f + 100.f * unit(gen);
        k.x = 60.f * unit(gen) - 30.f;
        k.phi = i % 17 == 0   ? 1.f
                : i % 19 == 0 ? 0.f
                              : 1.f - std::pow(10.f, -6.f * unit(gen));
        k.n = std::floor(1.f + 20000.f * unit(gen) * unit(gen));
        float r = std::sqrt(unit(gen)), a = 2.f * kPi * unit(gen);
        k.alpha = r * std::cos(a);
        k.beta = r * std::sin(a);
        const double mag = i % 5 == 0 ? 1.0 + (unit(gen) - 0.5) * 1e-6
                                      : std::pow(10.0, -30.0 + 68.0 * unit(gen));
        const Vec3 d = sample_uniform_sphere(unit(gen), unit(gen));
        k.px = float(d.x * mag), k.py = float(d.y * mag), k.pz = float(d.z * mag);
        cases.push_back(k);
    }
    return cases;
}

// |sqrt(y + d) - sqrt(y)| for |d| <= delta: what rounding of 1 - c^2 does to a sine.
double sqrt_error(double y, double delta) {
    return std::min(std::sqrt(delta), delta / (2.0 * std::sqrt(std::max(y, 1e-300))));
}

// Relative error of the device's exp(x) for an exact argument.
double exp_rel(double x) { return (3.0 + 2.0 * std::abs(x)) * 2.0 * kEps; }

// Absolute error of portable.glsl's log1p(x): its series for |x| < 1e-2, else the
// device's log of 1 + x (rounded first).
double log1p_error(double x) {
    const double v = std::abs(std::log1p(x));
    if (std::abs(x) < 1e-2) return 8.0 * kEps * v;
    const double y = 1.0 + x;
    return (y >= 0.5 && y <= 2.0 ? kLogAbs : 6.0 * kEps * v) + 2.0 * kEps;
}

TEST(SharedMathOnGpu, MatchesTheCpuWithinTheDevicesPrecision) {
    std::unique_ptr<VulkanCompute> vk;
    try {
        vk = std::make_unique<VulkanCompute>();
    } catch (const GpuUnavailable& e) {
        GTEST_SKIP() << "no Vulkan device: " << e.what();
    }
    const std::vector<Case> cases = make_cases(20000);
    const uint32_t n = uint32_t(cases.size());
    static_assert(sizeof(Case) == kIn * sizeof(float));
    const auto in = vk->create_buffer(n * sizeof(Case));
    const auto out = vk->create_buffer(size_t(n) * kOut * sizeof(float));
    vk->upload(in, cases.data(), n * sizeof(Case));
    const auto pipeline =
        vk->create_pipeline(kTestSharedMath, std::size(kTestSharedMath), 2, sizeof n);
    vk->run(pipeline, {in, out}, &n, sizeof n, (n + 63) / 64);
    std::vector<float> o(size_t(n) * kOut);
    vk->download(out, o.data(), o.size() * sizeof(float));

    const char* names[kOut] = {"hg_eval",
                               "hg_sample_cos",
                               "hg_sample.x",
                               "hg_sample.y",
                               "hg_sample.z",
                               "fresnel R",
                               "cos_t",
                               "sample_exponential",
                               "softplus",
                               "survival_power",
                               "event_weight_sum",
                               "first_event_probability",
                               "exit.x",
                               "exit.y",
                               "exit.z",
                               "expm1 * copysign",
                               "disc.a",
                               "disc.b",
                               "ball.x",
                               "ball.y",
                               "ball.z",
                               "unit.x",
                               "unit.y",
                               "unit.z"};
    double worst[kOut] = {};  // largest |gpu - cpu| / tolerance per output
    for (uint32_t i = 0; i < n; ++i) {
        const Case& k = cases[i];
        const float* gpu = &o[size_t(i) * kOut];
        double want[kOut], tol[kOut];

        const double g = k.g, c = k.c;
        want[0] = hg_eval(k.c, k.g);
        const double denom = 1.0 + g * g - 2.0 * g * c;
        tol[0] = 16.0 * kEps * (1.0 + g * g + 2.0 * std::abs(g * c)) / denom * want[0];

        want[1] = hg_sample_cos(k.u1, k.g);
        double tol_cos = 4.0 * kEps;
        if (std::abs(g) >= kHgIsotropicG) {
            const double sq = (1.0 - g * g) / (1.0 - g + 2.0 * g * k.u1);
            tol_cos = 16.0 * kEps * (1.0 + g * g + 3.0 * sq * sq) / (2.0 * std::abs(g));
        }
        tol[1] = tol_cos;

        const Vec3 wi = sample_uniform_sphere(k.u2, k.u1);
        const double z_wi = 1.0 - 2.0 * double(k.u2);
        const Vec3 w = hg_sample(wi, k.g, k.u1, k.u2);
        // The sine of HG's angle from its cosine, both spheres' sin and cos, the frames.
        const double c_s = want[1];
        const double tol_dir = sqrt_error(1.0 - c_s * c_s, 2.0 * tol_cos + 4.0 * kEps) +
                               sqrt_error(1.0 - z_wi * z_wi, 16.0 * kEps) +
                               4.0 * kTrigAbs + 64.0 * kEps;
        for (int j = 0; j < 3; ++j) want[2 + j] = w[j], tol[2 + j] = tol_dir;

        float cos_t = 0.f;
        want[5] = fresnel_dielectric(k.cos_i, k.eta, cos_t);
        want[6] = cos_t;
        const double sin2_t = (1.0 - double(k.cos_i) * k.cos_i) / (double(k.eta) * k.eta);
        tol[6] = sqrt_error(std::max(1.0 - sin2_t, 0.0), 8.0 * kEps);
        // |dR / dcos_t| <= 2 / (eta cos_i) + 2 eta / cos_i
        tol[5] = 8.0 * kEps + tol[6] * (2.0 / (k.eta * k.cos_i) + 2.0 * k.eta / k.cos_i);

        want[7] = sample_exponential(k.u1, k.sigma);
        tol[7] = (log1p_error(-double(k.u1)) + 4.0 * kEps * want[7] * k.sigma) / k.sigma;

        want[8] = softplus(k.x);
        const double ex = std::exp(double(k.x));
        tol[8] =
            k.x > kSoftplusThreshold
                ? 0.0
                : log1p_error(ex) + exp_rel(k.x) * ex / (1.0 + ex) + 4.0 * kEps * want[8];

        // phi^N = exp(x) with x = N log1p(phi - 1), off by dx on the device.
        // (phi = 0 and 1 take exact branches.)
        const double phi = k.phi;
        const bool inner = phi > 0.0 && phi < 1.0;
        const double x_n = inner ? double(k.n) * std::log(phi) : 0.0;
        const double dx =
            inner ? double(k.n) * log1p_error(phi - 1.0) + 4.0 * kEps * std::abs(x_n)
                  : 0.0;
        want[9] = survival_power(k.phi, k.n);
        tol[9] = inner ? (dx + exp_rel(x_n)) * want[9] + 1e-37 : 0.0;
        want[10] = event_weight_sum(k.phi, k.n);
        want[11] = first_event_probability(k.phi, k.n);
        // Both divide by 1 - phi^N = -expm1(x): its relative error is phi^N / (1 - phi^N)
        // times the error of phi^N (the series near x = 0 adds only rounding).
        double rel_q = 4.0 * kEps;
        if (inner) {
            const double q = -std::expm1(x_n);
            rel_q = 16.0 * kEps +
                    (1.0 - q) / q * (dx + (std::abs(x_n) < 1e-2 ? 0.0 : exp_rel(x_n)));
        }
        tol[10] = rel_q * want[10];
        tol[11] = rel_q * want[11];

        const Frame f = sphere_step_frame(wi, k.u2);
        const Vec3 e = f.to_world(sphere_exit_direction(k.c, k.alpha, k.beta));
        const double r2 = double(k.alpha) * k.alpha + double(k.beta) * k.beta;
        const double tol_exit =
            sqrt_error(1.0 - r2, 8.0 * kEps) + sqrt_error(1.0 - c * c, 8.0 * kEps) +
            sqrt_error(1.0 - z_wi * z_wi, 16.0 * kEps) + 8.0 * kTrigAbs + 64.0 * kEps;
        for (int j = 0; j < 3; ++j) want[12 + j] = e[j], tol[12 + j] = tol_exit;

        want[15] = std::expm1(double(k.x) * 1e-3) * (std::signbit(k.c) ? -1.0 : 1.0);
        tol[15] = std::abs(k.x * 1e-3f) < 1e-2f ? 16.0 * kEps * std::abs(want[15])
                                                : kLogAbs + exp_rel(k.x * 1e-3);

        // The projections: float arithmetic on the device where the CPU has double, and
        // at most one nudge more or less (2^-24 each).
        float pa = k.px, pb = k.py;
        project_into_disc(pa, pb);
        const Vec3 p(k.px, k.py, k.pz), ball = project_into_ball(p), unit = unit_or_z(p);
        const double want_p[8] = {pa, pb, ball.x, ball.y, ball.z, unit.x, unit.y, unit.z};
        for (int j = 0; j < 8; ++j) want[16 + j] = want_p[j], tol[16 + j] = 16.0 * kEps;

        for (int j = 0; j < kOut; ++j) {
            const double err = std::abs(double(gpu[j]) - want[j]);
            ASSERT_TRUE(std::isfinite(gpu[j])) << names[j] << ", case " << i;
            ASSERT_LE(err, tol[j]) << names[j] << ", case " << i << ": gpu " << gpu[j]
                                   << ", cpu " << want[j];
            worst[j] = std::max(worst[j], tol[j] > 0.0 ? err / tol[j] : 0.0);
        }
    }
    std::string summary;
    for (int j = 0; j < kOut; ++j)
        summary += std::string(names[j]) + " " + std::to_string(worst[j]) + "; ";
    RecordProperty("worst_error_over_tolerance", summary);
}

}  // namespace
}  // namespace sss

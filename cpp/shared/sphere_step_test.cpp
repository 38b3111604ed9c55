#include "shared/sphere_step.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"
#include "shared/sampling.h"

using namespace sss;

TEST(SphereStep, FrameIsRightHandedWithZAlongTheDirection) {
    Rng rng(7);
    for (int i = 0; i < 1000; ++i) {
        Vec3 w = sample_uniform_sphere(rng.uniform(), rng.uniform());
        float u = rng.uniform();
        Frame f = sphere_step_frame(w, u);
        EXPECT_EQ(f.n, w);
        EXPECT_NEAR(length(f.s), 1.f, 1e-5f);
        EXPECT_NEAR(length(f.t), 1.f, 1e-5f);
        EXPECT_NEAR(dot(f.s, f.t), 0.f, 1e-5f);
        EXPECT_NEAR(dot(f.s, w), 0.f, 1e-5f);
        Vec3 c = cross(f.s, f.t);
        EXPECT_NEAR(length(c - w), 0.f, 2e-5f);
    }
    // u = 0 is Frame::from_z; u = 1/4 turns it by 90 degrees about w.
    Vec3 w = normalize(Vec3(0.3f, -0.5f, 0.8f));
    Frame f0 = Frame::from_z(w), f = sphere_step_frame(w, 0.f),
          q = sphere_step_frame(w, 0.25f);
    EXPECT_EQ(f.s, f0.s);
    EXPECT_NEAR(length(q.s - f0.t), 0.f, 1e-6f);
    EXPECT_NEAR(length(q.t + f0.s), 0.f, 1e-6f);
}

TEST(SphereStep, ExitDirectionHasTheDocumentedComponents) {
    // alpha = w . b, beta = w . t, w . n = sqrt(1 - alpha^2 - beta^2), with b = +y,
    // t = (cos theta, 0, -sin theta), n = x (docs/model-format.md).
    Rng rng(3);
    for (int i = 0; i < 1000; ++i) {
        float c = 2.f * rng.uniform() - 1.f;
        float r = std::sqrt(rng.uniform()), a = 2.f * kPi * rng.uniform();
        float alpha = r * std::cos(a), beta = r * std::sin(a);
        Vec3 x = sphere_exit_point(c), w = sphere_exit_direction(c, alpha, beta);
        float s = std::sqrt(1.f - c * c);
        EXPECT_NEAR(length(x), 1.f, 1e-6f);
        EXPECT_NEAR(length(w), 1.f, 1e-5f);
        EXPECT_NEAR(w.y, alpha, 1e-6f);
        EXPECT_NEAR(dot(w, Vec3(c, 0.f, -s)), beta, 1e-5f);
        EXPECT_NEAR(dot(w, x),
                    std::sqrt(std::max(0.f, 1.f - alpha * alpha - beta * beta)), 1e-5f);
    }
    // No tangential part: the photon leaves along the exit normal (the N = 1 case).
    Vec3 x = sphere_exit_point(0.6f);
    EXPECT_NEAR(length(sphere_exit_direction(0.6f, 0.f, 0.f) - x), 0.f, 1e-6f);
}

TEST(SphereStep, WeightsMatchTheirSums) {
    for (double phi : {0.0, 0.3, 0.9, 0.99, 0.999999, 1.0}) {
        for (int64_t n : {1, 2, 7, 1000}) {
            long double sum = 0, power = 1;
            for (int64_t j = 1; j <= n; ++j) {
                power *= phi;
                sum += power;
            }
            EXPECT_NEAR(survival_power(phi, n), double(power),
                        1e-12 * std::max(1.0, double(power)))
                << phi << " " << n;
            EXPECT_NEAR(event_weight_sum(phi, n), double(sum),
                        1e-9 * std::max(1.0, double(sum)))
                << phi << " " << n;
        }
    }
    // N = 1: the centre alone, Lambda = phi; phi = 1: Lambda = N.
    EXPECT_NEAR(event_weight_sum(0.7, 1), 0.7, 1e-15);
    EXPECT_EQ(event_weight_sum(1.0, 123), 123.0);
    EXPECT_EQ(survival_power(0.0, 5), 0.0);
    // A huge N does not overflow or produce NaN.
    EXPECT_EQ(survival_power(0.5, int64_t(1) << 40), 0.0);
    EXPECT_NEAR(event_weight_sum(0.5, int64_t(1) << 40), 1.0, 1e-12);
}

// The decoders' outputs made valid, over magnitudes from 1e-30 to 1e38 (float's range:
// the lengths must not overflow) and near the unit circle and sphere: inside stays as it
// is, outside lands inside along the same direction, on the boundary within float
// rounding.
TEST(SphereStep, ProjectionsKeepTheDirectionAndNeverOverflow) {
    Rng rng(11);
    for (int i = 0; i < 20000; ++i) {
        const double mag = i % 5 == 0 ? 1.0 + (rng.uniform() - 0.5) * 1e-6
                                      : std::pow(10.0, -30.0 + 68.0 * rng.uniform());
        const Vec3 dir = sample_uniform_sphere(rng.uniform(), rng.uniform());
        const Vec3 v = dir * float(mag);
        const double len3 =
            std::sqrt(double(v.x) * v.x + double(v.y) * v.y + double(v.z) * v.z);
        const double len2 = std::sqrt(double(v.x) * v.x + double(v.y) * v.y);

        float a = v.x, b = v.y;
        project_into_disc(a, b);
        ASSERT_LE(a * a + b * b, 1.f) << v.x << " " << v.y;
        if (len2 <= 1.0) {
            EXPECT_EQ(a, v.x);
            EXPECT_EQ(b, v.y);
        } else {
            EXPECT_NEAR(a, v.x / len2, 4e-7) << v.x << " " << v.y;
            EXPECT_NEAR(b, v.y / len2, 4e-7) << v.x << " " << v.y;
        }

        const Vec3 x = project_into_ball(v);
        ASSERT_LE(dot(x, x), 1.f) << v.x << " " << v.y << " " << v.z;
        const Vec3 w = unit_or_z(v);
        for (int c = 0; c < 3; ++c) {
            if (len3 <= 1.0)
                EXPECT_EQ(x[c], v[c]);
            else
                EXPECT_NEAR(x[c], v[c] / len3, 4e-7);
            EXPECT_NEAR(w[c], v[c] / len3, 4e-7);
        }
    }
    EXPECT_EQ(unit_or_z(Vec3(0.f)), Vec3(0.f, 0.f, 1.f));
    float a = 0.f, b = 0.f;
    project_into_disc(a, b);
    EXPECT_EQ(a, 0.f);
    EXPECT_EQ(b, 0.f);
    const float big = 3e38f;  // |(big, big)| overflows float
    a = big, b = -big;
    project_into_disc(a, b);
    EXPECT_NEAR(a, 0.70710678f, 1e-6f);
    EXPECT_NEAR(b, -0.70710678f, 1e-6f);
    const Vec3 w = unit_or_z(Vec3(big, big, big));
    EXPECT_NEAR(w.x, 0.57735027f, 1e-6f);
}

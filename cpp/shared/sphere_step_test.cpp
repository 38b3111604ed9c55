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

#include "media/sphere_walk.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/check.h"
#include "testing/stats.h"

namespace sss {
namespace {

SphereWalkBatch walks(float sigma, float g, float albedo, int64_t n, int threads = 2,
                      uint64_t first = 0) {
    return sphere_walks({sigma}, {g}, {albedo}, n, /*seed=*/7, first, threads);
}

// P(N = 1) = e^{-sigma}: the flight after the first event (at the centre) must exceed 1.
TEST(SphereWalk, SingleEventProbabilityIsExpMinusSigma) {
    const int64_t n = 100000;
    for (float sigma : {0.3f, 1.f, 2.5f}) {
        SphereWalkBatch b = walks(sigma, 0.4f, 1.f, n);
        int64_t ones = 0;
        for (int64_t N : b.N) ones += N == 1;
        double p = std::exp(-double(sigma)), se = std::sqrt(p * (1 - p) / n);
        EXPECT_NEAR(double(ones) / n, p, 4.5 * se) << "sigma " << sigma;
    }
}

// Invariants of every walk: N >= 1, the exit direction leaves the sphere, the
// representative event lies inside it and its direction is a unit vector.
TEST(SphereWalk, OutputsSatisfyTheirConstraints) {
    for (float g : {-0.9f, 0.f, 0.9f}) {
        SphereWalkBatch b = walks(8.f, g, 0.9f, 20000);
        for (size_t i = 0; i < b.N.size(); ++i) {
            ASSERT_GE(b.N[i], 1);
            ASSERT_LE(std::abs(b.cos_theta[i]), 1.f);
            ASSERT_LE(b.alpha[i] * b.alpha[i] + b.beta[i] * b.beta[i], 1.f);
            Vec3 X{b.X[3 * i], b.X[3 * i + 1], b.X[3 * i + 2]};
            Vec3 W{b.W[3 * i], b.W[3 * i + 1], b.W[3 * i + 2]};
            ASSERT_LE(length(X), 1.f + 1e-6f);
            ASSERT_NEAR(length(W), 1.f, 1e-5f);
            if (b.N[i] ==
                1) {  // single scattering: exit straight along the first direction
                ASSERT_EQ(X, Vec3(0.f));
                ASSERT_EQ(W, Vec3(0.f, 0.f, 1.f));
                ASSERT_EQ(b.alpha[i], 0.f);
                ASSERT_EQ(b.beta[i], 0.f);
            }
        }
    }
}

// With albedo 0 only the first event (the centre) carries weight.
TEST(SphereWalk, ZeroAlbedoKeepsTheCentreAsRepresentativeEvent) {
    SphereWalkBatch b = walks(10.f, 0.f, 0.f, 2000);
    for (size_t i = 0; i < b.N.size(); ++i) {
        ASSERT_EQ(b.X[3 * i] + b.X[3 * i + 1] + b.X[3 * i + 2], 0.f);
        ASSERT_EQ(b.W[3 * i + 2], 1.f);
    }
}

// With albedo 1 every event is equally likely: the chosen index is uniform in 1..N, so
// the centre is chosen with probability E[1/N].
TEST(SphereWalk, UnitAlbedoChoosesEventsUniformly) {
    const int64_t n = 200000;
    SphereWalkBatch b = walks(3.f, 0.f, 1.f, n);
    double expected = 0, centre = 0, var = 0;
    for (int64_t i = 0; i < n; ++i) {
        double p = 1.0 / double(b.N[i]);
        expected += p;
        var += p * (1 - p);
        centre += b.X[3 * i] == 0.f && b.X[3 * i + 1] == 0.f && b.X[3 * i + 2] == 0.f;
    }
    EXPECT_NEAR(centre, expected, 4.5 * std::sqrt(var));
}

// sigma = 0: one event, the exit direction is the first HG direction, cos theta ~ HG
// (chi^2).
TEST(SphereWalk, NoScatteringLimitFollowsHenyeyGreenstein) {
    for (float g : {-0.7f, 0.f, 0.4f, 0.9f}) {
        const int64_t n = 200000;
        const int bins = 40;
        SphereWalkBatch b = walks(0.f, g, 1.f, n);
        std::vector<double> count(bins, 0.0);
        for (int64_t i = 0; i < n; ++i) {
            ASSERT_EQ(b.N[i], 1);
            int k = std::min(bins - 1, int((b.cos_theta[i] + 1.f) * 0.5f * bins));
            ++count[k];
        }
        // CDF of cos theta under HG.
        auto cdf = [g](double c) {
            if (std::abs(g) < 1e-3) return 0.5 * (1 + c);
            double gg = g;
            return (1 - gg * gg) / (2 * gg) *
                   (1 / std::sqrt(1 + gg * gg - 2 * gg * c) - 1 / (1 + gg));
        };
        double chi2 = 0;
        int dof = 0;
        for (int k = 0; k < bins; ++k) {
            double e = n * (cdf(-1 + 2.0 * (k + 1) / bins) - cdf(-1 + 2.0 * k / bins));
            if (e < 5) continue;
            chi2 += (count[k] - e) * (count[k] - e) / e;
            ++dof;
        }
        EXPECT_LT(chi2, test::chi2_critical(dof - 1)) << "g " << g;
    }
}

// The same walks for any thread count and any split into batches.
TEST(SphereWalk, ReproducibleForAnyThreadCountAndBatching) {
    SphereWalkBatch one = walks(20.f, 0.3f, 0.99f, 3000, 1);
    SphereWalkBatch three = walks(20.f, 0.3f, 0.99f, 3000, 3);
    SphereWalkBatch tail = walks(20.f, 0.3f, 0.99f, 1000, 2, 2000);
    EXPECT_EQ(one.N, three.N);
    EXPECT_EQ(one.X, three.X);
    EXPECT_EQ(one.W, three.W);
    EXPECT_EQ(one.cos_theta, three.cos_theta);
    for (int i = 0; i < 1000; ++i) {
        ASSERT_EQ(one.N[2000 + i], tail.N[i]);
        ASSERT_EQ(one.alpha[2000 + i], tail.alpha[i]);
    }
}

TEST(SphereWalk, RejectsInvalidParameters) {
    EXPECT_THROW(walks(-1.f, 0.f, 1.f, 10), Error);
    EXPECT_THROW(walks(NAN, 0.f, 1.f, 10), Error);
    EXPECT_THROW(walks(1e6f, 0.f, 1.f, 10), Error);
    EXPECT_THROW(walks(1.f, 1.f, 1.f, 10), Error);
    EXPECT_THROW(walks(1.f, 0.f, 1.5f, 10), Error);
    EXPECT_THROW(walks(1.f, 0.f, 1.f, -1), Error);
    EXPECT_THROW(sphere_walks({1.f, 2.f}, {0.f}, {1.f}, 3, 0), Error);
}

}  // namespace
}  // namespace sss

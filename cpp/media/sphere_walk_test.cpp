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

// With the plane at or beyond the sphere (h >= 1) and the photon arriving along +z, the
// cut sphere walk is the sphere walk: the same events, exit point and direction.
TEST(CutSphereWalk, WithoutACutIsTheSphereWalk) {
    const int64_t n = 20000;
    SphereWalkBatch s = walks(6.f, 0.7f, 1.f, n);
    CutSphereWalkBatch c =
        cut_sphere_walks({6.f}, {0.7f}, {1.f}, {1.f}, {1.f}, n, /*seed=*/7);
    for (int64_t i = 0; i < n; ++i) {
        ASSERT_EQ(c.N[i], s.N[i]) << "walk " << i;
        ASSERT_EQ(c.through_plane[i], 0);
        // sphere_walk reports the exit in its exit frame: the point's z and, for the
        // direction, its components along n = x and b, t.
        ASSERT_EQ(c.exit_pos[3 * i + 2], s.cos_theta[i]);
        // ... and the same representative event (sphere_walk's is rotated about z).
        const Vec3 X{c.X[3 * i], c.X[3 * i + 1], c.X[3 * i + 2]};
        ASSERT_NEAR(X.z, s.X[3 * i + 2], 1e-6f);
        ASSERT_NEAR(X.x * X.x + X.y * X.y,
                    s.X[3 * i] * s.X[3 * i] + s.X[3 * i + 1] * s.X[3 * i + 1], 1e-5f);
        const Vec3 x{c.exit_pos[3 * i], c.exit_pos[3 * i + 1], c.exit_pos[3 * i + 2]};
        const Vec3 w{c.exit_dir[3 * i], c.exit_dir[3 * i + 1], c.exit_dir[3 * i + 2]};
        // The exit direction's tangential part, squared (rounding: a few ulps of 1).
        if (s.N[i] > 1)
            ASSERT_NEAR(1.f - dot(w, x) * dot(w, x),
                        s.alpha[i] * s.alpha[i] + s.beta[i] * s.beta[i], 1e-5f);
    }
}

// Without scattering after the centre (sigma = 0) the photon flies straight along its
// first direction, which meets the plane z = h before the sphere exactly when its
// cosine with +z exceeds h: P = 1 - F(h), F Henyey-Greenstein's distribution function
// of the cosine about w_in = +z.
TEST(CutSphereWalk, StraightFlightsLeaveThroughThePlaneWithTheirHgProbability) {
    const int64_t n = 200000;
    for (float g : {0.f, 0.5f, 0.9f})
        for (float h : {0.1f, 0.5f, 0.9f}) {
            CutSphereWalkBatch c = cut_sphere_walks({0.f}, {g}, {h}, {1.f}, {1.f}, n, 3);
            int64_t plane = 0;
            for (int64_t i = 0; i < n; ++i) plane += c.through_plane[i];
            const double x = h;
            const double F =
                g == 0.f
                    ? (1.0 + x) / 2.0
                    : (1.0 - g * g) / (2.0 * g) *
                          (1.0 / std::sqrt(1.0 + g * g - 2.0 * g * x) - 1.0 / (1.0 + g));
            const double p = 1.0 - F, se = std::sqrt(p * (1.0 - p) / double(n));
            EXPECT_NEAR(double(plane) / double(n), p, 4.5 * se)
                << "g " << g << " h " << h;
        }
}

// Every walk ends on the region's surface, leaving it: on the plane (z = h, inside the
// unit disc's cut, moving up) or on the cap (|x| = 1, z <= h, moving out).
TEST(CutSphereWalk, ExitsLieOnTheSurfaceAndLeaveIt) {
    for (float mu0 : {-1.f, -0.3f, 0.4f, 1.f}) {
        const int64_t n = 20000;
        CutSphereWalkBatch c =
            cut_sphere_walks({8.f}, {0.9f}, {0.3f}, {mu0}, {0.9f}, n, 5);
        int64_t plane = 0;
        for (int64_t i = 0; i < n; ++i) {
            ASSERT_GE(c.N[i], 1);
            const Vec3 x{c.exit_pos[3 * i], c.exit_pos[3 * i + 1], c.exit_pos[3 * i + 2]};
            const Vec3 w{c.exit_dir[3 * i], c.exit_dir[3 * i + 1], c.exit_dir[3 * i + 2]};
            ASSERT_NEAR(length(w), 1.f, 1e-5f);
            if (c.through_plane[i]) {
                ++plane;
                ASSERT_EQ(x.z, 0.3f);
                ASSERT_LE(x.x * x.x + x.y * x.y, 1.f - 0.09f + 1e-5f);
                ASSERT_GT(w.z, 0.f);
            } else {
                ASSERT_NEAR(length(x), 1.f, 1e-5f);
                ASSERT_LE(x.z, 0.3f + 1e-5f);
                ASSERT_GE(dot(w, x), -1e-5f);
            }
        }
        // Both ways out are taken (the plane is 0.3 radii away, the cap farther).
        EXPECT_GT(plane, n / 20) << "mu0 " << mu0;
        EXPECT_LT(plane, n - n / 20) << "mu0 " << mu0;
    }
}

TEST(CutSphereWalk, RejectsInvalidParameters) {
    EXPECT_THROW(cut_sphere_walks({1.f}, {0.f}, {0.f}, {1.f}, {1.f}, 10, 0), Error);
    EXPECT_THROW(cut_sphere_walks({1.f}, {0.f}, {NAN}, {1.f}, {1.f}, 10, 0), Error);
    EXPECT_THROW(cut_sphere_walks({1.f}, {0.f}, {0.5f}, {1.5f}, {1.f}, 10, 0), Error);
    EXPECT_THROW(cut_sphere_walks({1.f}, {1.f}, {0.5f}, {1.f}, {1.f}, 10, 0), Error);
    EXPECT_THROW(cut_sphere_walks({-1.f}, {0.f}, {0.5f}, {1.f}, {1.f}, 10, 0), Error);
    EXPECT_THROW(cut_sphere_walks({1.f, 2.f}, {0.f}, {0.5f}, {1.f}, {1.f}, 3, 0), Error);
    EXPECT_THROW(cut_sphere_walks({1.f}, {0.f}, {0.5f}, {1.f}, {1.5f}, 10, 0), Error);
}

}  // namespace
}  // namespace sss

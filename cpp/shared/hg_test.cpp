#include "shared/hg.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/rng.h"
#include "testing/stats.h"

using namespace sss;

class HgTest : public ::testing::TestWithParam<float> {};

// 2 pi * integral over cos of hg_eval = 1 (midpoint rule, fine enough for |g| <= 0.9).
TEST_P(HgTest, IntegratesToOne) {
    float g = GetParam();
    const int n = 200000;
    double sum = 0;
    for (int i = 0; i < n; ++i) sum += hg_eval(-1.f + 2.f * (i + 0.5f) / n, g);
    EXPECT_NEAR(2.0 * kPi * sum * 2.0 / n, 1.0, 2e-3);
}

// Sampled cosines against the analytic density: chi-square over equal-width bins.
TEST_P(HgTest, SamplingMatchesDensityChi2) {
    float g = GetParam();
    const int bins = 64, n = 400000;
    std::vector<double> observed(bins, 0.0);
    Rng rng(42, uint64_t(1000 * (g + 1)));
    double mean_cos = 0;
    for (int i = 0; i < n; ++i) {
        float c = hg_sample_cos(rng.uniform(), g);
        mean_cos += c;
        observed[std::min(bins - 1, int((c + 1.f) * 0.5f * bins))] += 1;
    }
    double chi2 = 0;
    int dof = 0;
    for (int b = 0; b < bins; ++b) {
        // Expected count: 2 pi * integral of hg over the bin (fine midpoint rule).
        double lo = -1.0 + 2.0 * b / bins, hi = lo + 2.0 / bins, p = 0;
        for (int k = 0; k < 100; ++k)
            p += hg_eval(float(lo + (hi - lo) * (k + 0.5) / 100), g);
        double expected = n * 2.0 * kPi * p * (hi - lo) / 100;
        if (expected < 5) continue;
        chi2 += (observed[b] - expected) * (observed[b] - expected) / expected;
        ++dof;
    }
    EXPECT_LT(chi2, sss::test::chi2_critical(dof - 1)) << "g = " << g;
    // The mean cosine of HG is g; its standard error is below sqrt(1/n).
    EXPECT_NEAR(mean_cos / n, g, 5.0 / std::sqrt(double(n)));
}

TEST_P(HgTest, SampledDirectionsAreUnitAndAroundIncoming) {
    float g = GetParam();
    Rng rng(7);
    Vec3 wi = normalize(Vec3(0.3f, -0.5f, 0.8f));
    double mean = 0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        Vec3 wo = hg_sample(wi, g, rng.uniform(), rng.uniform());
        ASSERT_NEAR(length(wo), 1.f, 1e-5f);
        mean += dot(wi, wo);
    }
    EXPECT_NEAR(mean / n, g, 5.0 / std::sqrt(double(n)));
}

// Near |g| = 1 the density stays finite and positive, with its peak (1 + |g|) / (4 pi (1
// - |g|)^2) where it points, even for a cosine a rounding took past +-1: 1 + g^2 - 2 g
// cos, computed directly, cancelled to 0 or below there (NaN pixels at g = 0.9999).
TEST(Hg, FiniteAndPeakedForAnisotropiesNearOne) {
    for (float g : {0.9995f, 0.9999f, 1.f - 0x1p-24f, -0.9999f}) {
        const float ag = std::abs(g), ahead = g > 0.f ? 1.f : -1.f;
        const double peak = (1.0 + ag) / (4.0 * double(kPi) * (1.0 - ag) * (1.0 - ag));
        for (float c : {ahead, std::nextafter(ahead, 2.f * ahead)})
            EXPECT_NEAR(hg_eval(c, g) / peak, 1.0, 1e-3)
                << "g = " << g << ", cos = " << c;
        for (float c : {-1.f, -0.5f, 0.f, 0.5f, 0.99999f, 1.f}) {
            const float p = hg_eval(c, g);
            EXPECT_TRUE(std::isfinite(p) && p > 0.f) << "g = " << g << ", cos = " << c;
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Anisotropies, HgTest, ::testing::Values(-0.7f, 0.f, 0.4f, 0.9f));

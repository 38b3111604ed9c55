#include "shared/sampling.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sss {
namespace {

// Survivors carry 1/q, others 0; the mean weight is 1 (unbiased) for q in [kMinRouletteQ,
// 1).
TEST(Roulette, WeightIsOneOverQForSurvivors) {
    EXPECT_EQ(roulette_weight(0.25f, 0.1f), 4.f);
    EXPECT_EQ(roulette_weight(0.25f, 0.25f), 0.f);
    EXPECT_EQ(roulette_weight(0.25f, 0.9f), 0.f);
    EXPECT_EQ(roulette_weight(1.f, 0.999f), 1.f);
    EXPECT_EQ(roulette_weight(3.f, 0.5f), 1.f);
    EXPECT_EQ(roulette_weight(0.f, 0.f), 0.f);
}

// u = 0 happens (24-bit uniforms: once in 2^24 draws). A tiny or denormal q must not give
// an infinite weight: 0 * inf is the NaN a 1000-density bunny render once produced.
TEST(Roulette, TinyProbabilitiesNeverGiveInfiniteWeights) {
    for (float q : {1e-45f, 1e-40f, 2e-39f, 1e-30f, 1e-21f, 1e-20f, 1e-10f}) {
        float w = roulette_weight(q, 0.f);
        EXPECT_TRUE(std::isfinite(w)) << q;
        EXPECT_TRUE(std::isfinite(0.f * w)) << q;
    }
}

// The weight depends on the pdfs' ratio alone, also where their squares leave float's
// range: a small light far away (pdf past 1.8e19: inf / inf was NaN), a huge one close by
// (below 1e-19: both strategies got weight 0).
TEST(PowerHeuristic, DependsOnTheRatioAtAnyScale) {
    EXPECT_EQ(power_heuristic(0.f, 0.f), 0.f);
    EXPECT_EQ(power_heuristic(0.f, 1.f), 0.f);
    EXPECT_EQ(power_heuristic(2.f, 0.f), 1.f);
    EXPECT_FLOAT_EQ(power_heuristic(3.f, 1.f), 0.9f);
    for (float scale : {1e-30f, 1e-20f, 1e-10f, 1.f, 1e10f, 1e20f, 1e30f}) {
        EXPECT_FLOAT_EQ(power_heuristic(3.f * scale, scale), 0.9f) << scale;
        EXPECT_FLOAT_EQ(power_heuristic(scale, 3.f * scale), 0.1f) << scale;
        EXPECT_EQ(power_heuristic(scale, 0.f), 1.f) << scale;
    }
    const float inf = INFINITY;
    EXPECT_EQ(power_heuristic(inf, 1.f), 1.f);
    EXPECT_EQ(power_heuristic(1.f, inf), 0.f);
    EXPECT_EQ(power_heuristic(inf, inf), 0.5f);
}

}  // namespace
}  // namespace sss

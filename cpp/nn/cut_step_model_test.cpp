#include "nn/cut_step_model.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/check.h"
#include "media/sphere_walk.h"
#include "nn/random_models.h"

using namespace sss;

namespace {

CutStepModel random_cut_model(uint64_t seed) {
    return CutStepModel(random_cut_decoder("CutLengthGen", seed),
                        random_cut_decoder("CutPathGen", seed + 1), "random cut models");
}

}  // namespace

// Whatever the networks say, a step is a valid exit of the region {|x| <= 1, z <= h}: on
// the plane or the cap, leaving it, with unit direction.
TEST(CutStepModel, EveryStepIsAValidExit) {
    const CutStepModel model = random_cut_model(5);
    Rng rng(11);
    int plane = 0;
    for (int i = 0; i < 20000; ++i) {
        const float sigma = 0.5f + 31.5f * rng.uniform(),
                    g = 1.9f * rng.uniform() - 0.95f;
        const float h = 0.01f + 0.99f * rng.uniform(), mu0 = 2.f * rng.uniform() - 1.f;
        const CutStep s = model.sample(sigma, g, h, mu0, rng);
        ASSERT_GE(s.N, 1);
        EXPECT_NEAR(length(s.exit_dir), 1.f, 1e-5f);
        if (s.through_plane) {
            ++plane;
            EXPECT_EQ(s.exit_pos.z, h);
            EXPECT_LE(length(s.exit_pos), 1.f + 1e-5f);
            EXPECT_GE(s.exit_dir.z, 0.f);
        } else {
            EXPECT_NEAR(length(s.exit_pos), 1.f, 1e-5f);
            EXPECT_LE(s.exit_pos.z, h + 1e-6f);
            EXPECT_GE(dot(s.exit_dir, s.exit_pos), -1e-6f);
        }
    }
    EXPECT_GT(plane, 1000);
    EXPECT_LT(plane, 19000);
}

// The first flight is exact: P(N = 1) is the ground truth's, whatever the networks (a
// binomial comparison with the exact walks, 5 standard errors).
TEST(CutStepModel, SingleScatteringIsExact) {
    const CutStepModel model = random_cut_model(7);
    struct Case {
        float sigma, g, h, mu0;
    };
    for (const Case c : {Case{0.7f, 0.f, 0.3f, 1.f}, Case{3.f, 0.8f, 0.15f, -0.5f},
                         Case{2.f, -0.6f, 0.6f, 0.2f}, Case{1.2f, 0.95f, 0.05f, 0.9f}}) {
        const int n = 40000;
        Rng a(1), b(2);
        int model_one = 0, walk_one = 0;
        for (int i = 0; i < n; ++i) {
            model_one += model.sample(c.sigma, c.g, c.h, c.mu0, a).N == 1;
            walk_one += cut_sphere_walk(c.sigma, c.g, c.h, c.mu0, 1.f, b).N == 1;
        }
        const double p = 0.5 * (model_one + walk_one) / n;
        const double se = std::sqrt(2.0 * p * (1.0 - p) / n);
        EXPECT_NEAR(double(model_one) / n, double(walk_one) / n, 5.0 * se + 1e-9)
            << "sigma " << c.sigma << " g " << c.g << " h " << c.h << " mu0 " << c.mu0;
    }
}

TEST(CutStepModel, RefusesInputsOutsideTheTrainingRanges) {
    const CutStepModel model = random_cut_model(3);
    Rng rng(1);
    EXPECT_THROW(model.sample(40.f, 0.5f, 0.3f, 0.f, rng), Error);
    EXPECT_THROW(model.sample(4.f, 0.99f, 0.3f, 0.f, rng), Error);
    EXPECT_THROW(model.sample(4.f, 0.5f, 0.f, 0.f, rng), Error);
    EXPECT_THROW(model.sample(4.f, 0.5f, NAN, 0.f, rng), Error);
    EXPECT_THROW(model.sample(4.f, 0.5f, 0.3f, 1.5f, rng), Error);
    EXPECT_NO_THROW(model.sample(4.f, 0.5f, 0.3f, 0.f, rng));
}

TEST(CutStepModel, RefusesTheWrongDecoders) {
    try {
        CutStepModel(random_decoder("LengthGen", 1), random_decoder("PathGen", 2), "x");
        FAIL() << "accepted the sphere models";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("expected 'CutLengthGen'"),
                  std::string::npos)
            << e.what();
    }
}

// sample_group gives each step what sample() gives it alone: the same random numbers
// drawn, the same scattering count and side of exit, and the same exit up to rounding. A
// group of more than four runs the networks on lanes, whose sums round differently from
// the one-path kernel, and the decodings magnify that (up to 2.4e-4 in a direction here,
// with random networks); a step taken from another lane would be off by O(1). The
// renderer groups steps by whichever paths wait together.
TEST(CutStepModel, AStepDoesNotDependOnItsGroup) {
    const CutStepModel model = random_cut_model(9);
    constexpr int n = 16;
    float sigma[n], g[n], h[n], mu0[n];
    Rng inputs(3);
    for (int k = 0; k < n; ++k) {
        sigma[k] = 0.5f + 31.5f * inputs.uniform();
        g[k] = 1.9f * inputs.uniform() - 0.95f;
        h[k] = 0.01f + 0.99f * inputs.uniform();
        mu0[k] = 2.f * inputs.uniform() - 1.f;
    }
    for (int size : {16, 3}) {
        Rng group_rng[n];
        for (int k = 0; k < size; ++k) group_rng[k] = Rng(17, uint64_t(k));
        CutStep group[n];
        model.sample_group(size, sigma, g, h, mu0, group_rng, group);
        // Groups of up to four take the one-path kernel: exactly sample()'s floats.
        const float tolerance = size > 4 ? 1e-3f : 0.f;
        for (int k = 0; k < size; ++k) {
            Rng alone_rng(17, uint64_t(k));
            const CutStep alone = model.sample(sigma[k], g[k], h[k], mu0[k], alone_rng);
            EXPECT_EQ(group[k].N, alone.N) << "step " << k << " of " << size;
            EXPECT_EQ(group[k].through_plane, alone.through_plane) << "step " << k;
            for (int a = 0; a < 3; ++a) {
                EXPECT_NEAR(group[k].exit_pos[a], alone.exit_pos[a], tolerance) << k;
                EXPECT_NEAR(group[k].exit_dir[a], alone.exit_dir[a], tolerance) << k;
            }
            EXPECT_EQ(group_rng[k].uniform(), alone_rng.uniform()) << "step " << k;
        }
    }
}

#include "render/sphere_tracing.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "core/check.h"
#include "render/camera.h"
#include "render/pt.h"
#include "render/renderer.h"
#include "shared/sphere_step.h"
#include "testing/errors.h"
#include "testing/model_dir.h"
#include "testing/scenes.h"
#include "testing/stats.h"

using namespace sss;

namespace {

using test::error_of;

// A sphere of radius 1 in a constant environment (optionally with a point light).
SceneDesc sphere_scene(Vec3 sigma_t, Vec3 albedo, float g, BoundaryType boundary,
                       bool point_light = false) {
    SceneDesc d = test::sphere_in_environment(sigma_t, albedo, g, boundary, point_light);
    d.source = "st-test";
    return d;
}

// Sums over one 4x4 pixel block and channel of the pixel means and their variances.
struct BlockSum {
    double value = 0, variance = 0;
    int pixels = 0;
};

// The block sums of r, block-major with the channel innermost. skip_constant leaves out
// pixels of zero variance (every sample the same, e.g. the background).
std::vector<BlockSum> block_sums(const RenderResult& r, bool skip_constant) {
    constexpr int B = 4;
    std::vector<BlockSum> out;
    for (int by = 0; by < r.height / B; ++by)
        for (int bx = 0; bx < r.width / B; ++bx)
            for (int c = 0; c < 3; ++c) {
                BlockSum b;
                for (int y = by * B; y < (by + 1) * B; ++y)
                    for (int x = bx * B; x < (bx + 1) * B; ++x) {
                        size_t i = 3 * (size_t(y) * r.width + x) + c;
                        if (skip_constant && r.variance[i] == 0.f) continue;
                        b.value += r.image[i];
                        b.variance += r.variance[i];
                        ++b.pixels;
                    }
                out.push_back(b);
            }
    return out;
}

// One channel's comparison over the blocks: chi-square of the block differences, their
// sum and its variance. Channels are checked one at a time: in a grey medium all three
// carry the same samples, so pooling them would count each block three times (a
// chi-square three times too wide, a whole-image sigma sqrt(3) too small).
struct ChannelTest {
    double chi2 = 0, diff = 0, var = 0;
    int blocks = 0;
};

// expect(k) -> (difference, variance) of block sum k (channel k % 3); variance 0 leaves
// it out.
template <class F>
std::array<ChannelTest, 3> per_channel(size_t blocks, F&& expect) {
    std::array<ChannelTest, 3> t;
    for (size_t k = 0; k < blocks; ++k) {
        const auto [d, v] = expect(k);
        if (v == 0.0) continue;
        ChannelTest& c = t[k % 3];
        c.chi2 += d * d / v;
        c.diff += d;
        c.var += v;
        ++c.blocks;
    }
    return t;
}

// Every channel: block chi-square under its p = 1e-4 critical value, the sum within 4
// sigma.
void expect_agreement(const std::array<ChannelTest, 3>& t, int min_blocks) {
    for (int c = 0; c < 3; ++c) {
        SCOPED_TRACE("channel " + std::to_string(c));
        ASSERT_GT(t[c].blocks, min_blocks);
        EXPECT_LT(t[c].chi2, test::chi2_critical(t[c].blocks))
            << "chi2 " << t[c].chi2 << " over " << t[c].blocks << " blocks";
        EXPECT_LT(std::abs(t[c].diff), 4.0 * std::sqrt(t[c].var))
            << "sum of differences " << t[c].diff << " +- " << std::sqrt(t[c].var);
    }
}

// Both renders' block sums agree (expect_agreement over the blocks of their difference).
void expect_same_image(const std::vector<BlockSum>& a, const std::vector<BlockSum>& b,
                       int min_blocks) {
    expect_agreement(per_channel(a.size(),
                                 [&](size_t k) {
                                     return std::pair(a[k].value - b[k].value,
                                                      a[k].variance + b[k].variance);
                                 }),
                     min_blocks);
}

// pt with NEE, 2 threads.
RenderOptions pt_options(int spp, uint64_t seed) {
    RenderOptions opt;
    opt.spp = spp;
    opt.threads = 2;
    opt.seed = seed;
    return opt;
}

RenderOptions st_options(const std::string& models, float threshold) {
    RenderOptions opt;
    opt.integrator = "st";
    opt.models = models;
    opt.sphere_threshold = threshold;
    opt.threads = 2;
    return opt;
}

// st with exact sphere walks in place of the networks (unbiased), tau = 1.
RenderOptions exact_walks(StepNee mode, int spp, uint64_t seed) {
    RenderOptions opt = st_options("", 1.f);
    opt.sphere_sampler = SphereSampler::Walk;
    opt.step_nee = mode;
    opt.spp = spp;
    opt.seed = seed;
    return opt;
}

}  // namespace

TEST(SphereTracer, FurnaceWithoutNeeIsExactPerPathForAnyModel) {
    // Albedo 1 in a uniform environment of radiance 1, no NEE: every path keeps weight 1
    // and escapes, whatever a (here random) model says about N and the exit. Every pixel
    // is 1.
    test::ModelDir models;
    models.write_random(2);
    for (BoundaryType b : {BoundaryType::IndexMatched, BoundaryType::Dielectric}) {
        Scene scene(sphere_scene(Vec3(20.f), Vec3(1.f), 0.6f, b), 2);
        RenderOptions opt = st_options(models.path(), 1.f);
        opt.nee = false;
        opt.spp = 8;
        RenderResult r = render(scene, opt);
        for (float v : r.image) ASSERT_NEAR(v, 1.f, 1e-5f);
        EXPECT_GT(r.total_sphere_steps, r.total_paths / 10);  // steps were taken
    }
}

TEST(SphereTracer, FurnaceWithNeeAndExactWalksIsUnbiased) {
    // With exact sphere walks in place of the networks, st with NEE must give the
    // furnace's 1 everywhere up to noise, whichever way the steps get their direct light
    // (StepNee::Event: Lambda-weighted connections from the representative event, MIS
    // for the first event only; Hits: the exit flight's hits of the environment). The
    // NEE weights (Lambda = N here) make single samples heavy-tailed, so pixel variances
    // from few samples are unreliable: the test compares 4x4-pixel block means
    // (chi-square) and the mean over the sphere, per channel.
    for (StepNee mode : {StepNee::Event, StepNee::Hits}) {
        for (Vec3 sigma_t : {Vec3(6.f), Vec3(2.f, 6.f, 12.f)}) {
            SCOPED_TRACE(mode == StepNee::Event ? "event" : "hits");
            Scene scene(
                sphere_scene(sigma_t, Vec3(1.f), 0.5f, BoundaryType::IndexMatched), 2);
            const RenderResult r = render(scene, exact_walks(mode, 128, 4));
            const std::vector<BlockSum> b = block_sums(r, true);
            // Background-only blocks (no pixel left) are exactly 1 and left out.
            expect_agreement(per_channel(b.size(),
                                         [&](size_t k) {
                                             return std::pair(b[k].value - b[k].pixels,
                                                              b[k].variance);
                                         }),
                             6);
            EXPECT_GT(r.total_sphere_steps, r.total_paths / 10);
        }
    }
}

TEST(SphereTracer, ExactWalksUnderAllKindsOfLightMatchPt) {
    // A large area light above an index-matched sphere, a point light and the
    // environment. StepNee::Event: NEE from a step's events k >= 2 has no MIS partner, so
    // it combines a light sample and a phase-sampled ray for the area light and takes
    // phase-sampled rays for the environment. StepNee::Hits: the steps' events see the
    // area light and the environment only through the exit flights' hits (weight 1), and
    // the balls keep kDeltaLightClearance mean free paths from the boundary (what the
    // point light gives their events is left out: below 1e-4 of the image here). With
    // exact walks st must agree with pt (NEE, MIS) up to noise in both modes: 4x4 block
    // means compared by chi-square, and the sum over the sphere (4 sigma), with both
    // renders' variances, per channel. A grey medium, and a chromatic one (spectral MIS
    // until the first step, then one channel picked afresh: the background stays exact).
    // Hits needs a denser sphere, and a whiter one that paths reach deep into, for steps
    // clear of the boundary.
    struct Case {
        StepNee mode;
        Vec3 sigma_t;
        float albedo;
    };
    for (const Case& c : {Case{StepNee::Event, Vec3(6.f), 0.95f},
                          Case{StepNee::Event, Vec3(4.f, 6.f, 10.f), 0.95f},
                          Case{StepNee::Hits, Vec3(20.f), 0.995f},
                          Case{StepNee::Hits, Vec3(20.f, 24.f, 32.f), 0.995f}}) {
        SCOPED_TRACE(std::string(c.mode == StepNee::Event ? "event" : "hits") +
                     ", sigma_t " + std::to_string(c.sigma_t.z));
        SceneDesc d = sphere_scene(c.sigma_t, Vec3(c.albedo), 0.7f,
                                   BoundaryType::IndexMatched, true);
        // edge1 x edge2 points down, at the sphere
        d.lights.push_back(parse_light(R"({"type": "area", "corner": [-1, 1.8, 1],
            "edge1": [0, 0, -2], "edge2": [2, 0, 0], "radiance": 5})"));
        d.camera.width = d.camera.height = 32;
        Scene scene(d, 2);
        const std::vector<BlockSum> sa =
            block_sums(render(scene, pt_options(256, 5)), false);
        const RenderResult b = render(scene, exact_walks(c.mode, 256, 6));
        // Blocks of background in both (the environment exactly) have variance 0.
        expect_same_image(sa, block_sums(b, false), 20);
        EXPECT_GT(b.total_sphere_steps, b.total_paths / 10);
        EXPECT_EQ(b.variance[0], 0.f);  // the corner pixel sees the environment only
    }
}

TEST(SphereTracer, CutStepsWithExactWalksMatchPt) {
    // Cut sphere steps with exact cut walks in place of the networks: st must agree with
    // pt up to noise (4x4 block means by chi-square, the sum over the image within 4
    // sigma, per channel). A smooth dielectric sphere, dense enough (R = 6 mean free
    // paths of 0.2 in a sphere of radius 1) for certified planes: this checks the
    // certificates, the walk's frame in the world, the weights and the channel choice,
    // not the models. Chromatic: spectral MIS until the first step.
    test::ModelDir cut;
    cut.write_random_cut(3);
    SceneDesc d = sphere_scene(Vec3(30.f, 40.f, 60.f), Vec3(0.9f, 0.95f, 0.85f), 0.6f,
                               BoundaryType::Dielectric);
    d.camera.width = d.camera.height = 24;
    Scene scene(d, 2);
    const std::vector<BlockSum> sa = block_sums(render(scene, pt_options(256, 5)), false);
    // tau = 6: collisions up to 6 mean free paths deep are left to delta tracking or cut
    // steps (with tau = 1 the sphere's curvature would leave no room for certified planes
    // in the thinner layer).
    RenderOptions st = exact_walks(StepNee::Hits, 256, 6);
    st.sphere_threshold = 6.f;
    st.cut_models = cut.path();
    const RenderResult b = render(scene, st);
    expect_same_image(sa, block_sums(b, false), 10);
    // Cut steps were taken: they stand for many of the ordinary events near the surface.
    RenderOptions no_cuts = st;
    no_cuts.cut_models.clear();
    const RenderResult without = render(scene, no_cuts);
    EXPECT_LT(b.total_events, without.total_events * 3 / 4)
        << b.total_events << " ordinary events with cut steps, " << without.total_events
        << " without";
}

TEST(SphereTracer, FurnaceWithCutStepsIsExactPerPathForAnyModel) {
    // Albedo 1 in a uniform environment, no NEE: whatever (random) cut models say, every
    // path keeps weight 1 and leaves: every pixel is 1.
    test::ModelDir models, cut("_cut");
    models.write_random(2);
    cut.write_random_cut(4);
    Scene scene(sphere_scene(Vec3(40.f), Vec3(1.f), 0.6f, BoundaryType::Dielectric), 2);
    RenderOptions opt = st_options(models.path(), 6.f);
    opt.cut_models = cut.path();
    opt.nee = false;
    opt.spp = 4;
    const RenderResult r = render(scene, opt);
    for (float v : r.image) ASSERT_NEAR(v, 1.f, 1e-5f);
}

TEST(SphereTracer, CutStepsRefuseModelsThatDoNotCoverThem) {
    test::ModelDir cut;
    Decoder length = random_cut_decoder("CutLengthGen", 1);
    Decoder path = random_cut_decoder("CutPathGen", 2);
    for (Decoder* dec : {&length, &path}) dec->training_ranges[2].second.lo = 0.2;  // h
    cut.write(length);
    cut.write(path);
    Scene scene(sphere_scene(Vec3(40.f), Vec3(0.9f), 0.6f, BoundaryType::Dielectric), 2);
    RenderOptions opt = exact_walks(StepNee::Hits, 1, 1);
    opt.cut_models = cut.path();
    try {
        render(scene, opt);
        FAIL() << "accepted cut models without the planes the steps need";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("do not cover"), std::string::npos)
            << e.what();
    }
}

TEST(SphereTracer, InfiniteThresholdGivesPtBitForBit) {
    // tau = inf runs st's code (a grid query at every collision) but never steps: the
    // image, its variance and the event counts are pt's exactly. No models are needed.
    for (BoundaryType b : {BoundaryType::IndexMatched, BoundaryType::Dielectric}) {
        Scene scene(
            sphere_scene(Vec3(3.f, 8.f, 20.f), Vec3(0.9f, 0.8f, 0.95f), 0.4f, b, true),
            2);
        RenderOptions pt;
        pt.spp = 8;
        pt.threads = 2;
        RenderOptions st = st_options("", std::numeric_limits<float>::infinity());
        st.spp = 8;
        RenderResult a = render(scene, pt), c = render(scene, st);
        EXPECT_EQ(a.image, c.image);
        EXPECT_EQ(a.variance, c.variance);
        EXPECT_EQ(a.events, c.events);
        EXPECT_EQ(c.total_sphere_steps, 0u);
    }
}

TEST(SphereTracer, WhereNoStepFitsItIsPt) {
    // A sphere of radius 1 with sigma_t 3 (the largest optical radius is 3) and tau = 6:
    // no step fits anywhere, so may_step() is false and the renderer traces st as pt
    // (the image would be pt's either way; the flag is what this test pins down). A
    // path's first step comes where it goes on in one channel, where a step fits
    // spectral_switch_extinction (the smallest channel's, or half the largest if more):
    // (3, 3, 9) gives 4.5 and fits none, (3, 3, 20) 10 and (7, 9, 12) 7 fit one at the
    // centre. Under a point light
    // (StepNee::Hits, NEE on) a ball also keeps kDeltaLightClearance = 10 mean free paths
    // from the boundary: (7, 9, 12) then fits none, (17, 19, 22) does.
    test::ModelDir models;
    models.write_random(2);
    auto sphere = [](Vec3 sigma_t, bool point_light) {
        return sphere_scene(sigma_t, Vec3(0.9f), 0.4f, BoundaryType::IndexMatched,
                            point_light);
    };
    auto may_step = [&](const Scene& scene, bool nee, StepNee mode = StepNee::Hits) {
        return SphereTracing(scene, 6.f, SphereSampler::Model, models.path(), nee, mode)
            .may_step();
    };
    Scene thin(sphere(Vec3(3.f), false), 2),
        one_channel(sphere(Vec3(3.f, 3.f, 9.f), false), 2),
        one_dense_channel(sphere(Vec3(3.f, 3.f, 20.f), false), 2),
        deep(sphere(Vec3(7.f, 9.f, 12.f), false), 2),
        deep_lit(sphere(Vec3(7.f, 9.f, 12.f), true), 2),
        deeper_lit(sphere(Vec3(17.f, 19.f, 22.f), true), 2);
    EXPECT_FALSE(may_step(one_channel, true));
    EXPECT_TRUE(may_step(one_dense_channel, true));
    EXPECT_FALSE(may_step(thin, true));
    EXPECT_TRUE(may_step(deep, true));
    EXPECT_FALSE(may_step(deep_lit, true));
    EXPECT_TRUE(may_step(deep_lit, false));  // no NEE: no clearance
    EXPECT_TRUE(
        may_step(deep_lit, true, StepNee::Event));  // EventGen's connection instead
    EXPECT_TRUE(may_step(deeper_lit, true));
    RenderOptions st = st_options(models.path(), 6.f);
    st.spp = 4;
    RenderOptions pt;
    pt.spp = 4;
    pt.threads = 2;
    for (const Scene* scene : {&thin, &one_channel, &deep_lit}) {
        RenderResult a = render(*scene, pt), c = render(*scene, st);
        EXPECT_EQ(a.image, c.image);
        EXPECT_EQ(c.total_sphere_steps, 0u);
    }
    EXPECT_GT(render(deep, st).total_sphere_steps, 0u);
    EXPECT_GT(render(one_dense_channel, st).total_sphere_steps, 0u);
}

TEST(SphereTracer, BallsKeepClearOfTheBoundaryAndPointLights) {
    // Where a step's events would need light sampling of a point or directional light
    // (StepNee::Hits, NEE, an index-matched boundary), the ball keeps
    // kDeltaLightClearance mean free paths from the boundary and from every point light;
    // elsewhere it is the grid's bound. Extinction 100: the clearance is 0.1.
    test::ModelDir models;
    models.write_random(2);
    const float c = kDeltaLightClearance / 100.f;
    auto tracing = [&](const Scene& scene, bool nee, StepNee mode = StepNee::Hits) {
        return std::make_unique<SphereTracing>(scene, 6.f, SphereSampler::Model,
                                               models.path(), nee, mode);
    };
    SceneDesc inside =
        sphere_scene(Vec3(100.f), Vec3(0.9f), 0.4f, BoundaryType::IndexMatched);
    inside.lights.push_back(
        parse_light(R"({"type": "point", "position": [0.2, 0, 0], "intensity": 1})"));
    Scene lit_inside(inside, 2);
    auto st = tracing(lit_inside, true);
    EXPECT_EQ(st->clearance(0), kDeltaLightClearance);
    EXPECT_FLOAT_EQ(st->step_radius(0, Vec3(0.f), 0.9f, 100.f), 0.2f - c);
    EXPECT_FLOAT_EQ(st->step_radius(0, Vec3(0.f, 0.5f, 0.f), 0.45f, 100.f),
                    0.45f - c);  // the light is farther than the boundary
    EXPECT_LT(st->step_radius(0, Vec3(0.2f, 0.f, 0.f), 0.7f, 100.f),
              0.f);  // at the light
    // sigma r = 15 < tau + c = 16: no ball, whatever the lights.
    EXPECT_LT(100.f * st->step_radius(0, Vec3(0.f, 0.5f, 0.f), 0.15f, 100.f), 6.f);
    EXPECT_EQ(tracing(lit_inside, false)->clearance(0), 0.f);
    EXPECT_EQ(tracing(lit_inside, true, StepNee::Event)->clearance(0), 0.f);
    EXPECT_EQ(tracing(lit_inside, false)->step_radius(0, Vec3(0.f), 0.9f, 100.f), 0.9f);

    SceneDesc sun =
        sphere_scene(Vec3(100.f), Vec3(0.9f), 0.4f, BoundaryType::IndexMatched);
    sun.lights.push_back(parse_light(
        R"({"type": "directional", "direction": [0, -1, 0], "irradiance": 1})"));
    Scene sunlit(sun, 2);
    EXPECT_FLOAT_EQ(tracing(sunlit, true)->step_radius(0, Vec3(0.f), 0.9f, 100.f),
                    0.9f - c);
    // No shadow ray leaves a dielectric boundary: its events sample no light anyway.
    sun.shapes[0].boundary = test::boundary(BoundaryType::Dielectric);
    Scene glass(sun, 2);
    EXPECT_EQ(tracing(glass, true)->clearance(0), 0.f);
    // Area lights and the environment alone: the exit flights' hits.
    Scene env(sphere_scene(Vec3(100.f), Vec3(0.9f), 0.4f, BoundaryType::IndexMatched), 2);
    EXPECT_EQ(tracing(env, true)->clearance(0), 0.f);
}

TEST(SphereTracer, IdenticalForAnyThreadCount) {
    test::ModelDir models;
    models.write_random(3);
    Scene scene(sphere_scene(Vec3(15.f), Vec3(0.99f, 0.9f, 0.8f), 0.3f,
                             BoundaryType::IndexMatched, true),
                1);
    RenderOptions opt = st_options(models.path(), 2.f);
    opt.spp = 4;
    opt.threads = 1;
    RenderResult a = render(scene, opt);
    opt.threads = 3;
    RenderResult b = render(scene, opt);
    EXPECT_EQ(a.image, b.image);
    EXPECT_EQ(a.sphere_steps, b.sphere_steps);
    EXPECT_GT(a.total_sphere_steps, 0u);
}

// The renderer keeps many "st" paths in flight and samples their sphere steps together;
// each path still draws from its own stream, so every pixel is the mean of the same
// samples that tracing its paths one at a time (PathTracer::trace) gives. With a
// forward-memory tilt too (a strong one, refusing many draws), whose draws again fill
// the lanes of a call's later evaluations.
TEST(SphereTracer, PathsInFlightAreThePathsTracedOneAtATime) {
    test::ModelDir models;
    models.write_random(4);
    std::vector<float> untilted[2];  // variant 1's images, which the tilt must change
    for (int variant = 0; variant < 3; ++variant) {
        const StepNee mode = variant == 0 ? StepNee::Hits : StepNee::Event;
        const bool tilted = variant == 2;
        if (tilted)
            models.write("tilt.json", R"({"format": "sssphere-step-tilt",
                "format_version": 1, "sigma": [1], "g": [0], "a": [[0.6]], "b": [[-0.25]]})");
        for (bool chromatic : {false, true}) {
            Scene scene(sphere_scene(Vec3(15.f),
                                     chromatic ? Vec3(0.99f, 0.9f, 0.8f) : Vec3(0.95f),
                                     0.3f, BoundaryType::IndexMatched, true),
                        1);
            RenderOptions opt = st_options(models.path(), 2.f);
            opt.spp = 3;
            opt.seed = 7;
            opt.step_nee = mode;
            RenderResult r = render(scene, opt);
            ASSERT_GT(r.total_sphere_steps, 0u);
            if (variant == 1) untilted[chromatic] = r.image;
            if (tilted) EXPECT_NE(r.image, untilted[chromatic]);  // the tilt was taken

            SphereTracing st(scene, opt.sphere_threshold, SphereSampler::Model,
                             opt.models, true, mode);
            PathTracer tracer(scene, -1, true, &st);
            const Camera& cam = scene.desc().camera;
            PinholeCamera camera(cam);
            for (int y = 0; y < cam.height; ++y)
                for (int x = 0; x < cam.width; ++x) {
                    const size_t p = size_t(y) * cam.width + x;
                    double sum_d[3] = {0, 0, 0};
                    uint64_t events = 0, steps = 0;
                    for (int k = 0; k < opt.spp; ++k) {
                        Rng rng(opt.seed, p, uint64_t(k));
                        float jx = rng.uniform(), jy = rng.uniform();
                        const Vec3 d = camera.direction(x + jx, y + jy);
                        PathSample s = tracer.trace(
                            camera.origin() + d * scene.camera_ray_start(), d, rng);
                        for (int c = 0; c < 3; ++c) sum_d[c] += s.radiance[c];
                        events += s.scatter_events;
                        steps += s.sphere_steps;
                    }
                    for (int c = 0; c < 3; ++c) {
                        // The same samples summed in another order: equal to double
                        // rounding.
                        const double want = sum_d[c] / opt.spp;
                        EXPECT_NEAR(r.image[3 * p + c], want, 1e-6 * std::max(1.0, want))
                            << x << " " << y;
                    }
                    EXPECT_EQ(r.events[p], float(double(events) / opt.spp));
                    EXPECT_EQ(r.sphere_steps[p], float(double(steps) / opt.spp));
                }
        }
    }
}

TEST(SphereTracer, RefusesBadOptionsAndStepsNotWhereTheModelsCannot) {
    test::ModelDir models;
    models.write_random(1, [](Decoder& d) {
        test::set_training_range(d, "sigma", 0.5, 150.0);
        test::set_training_range(d, "g", -0.5, 0.5);
        test::set_training_range(d, "phi", 0.0, 0.9);
    });
    SceneDesc desc =
        sphere_scene(Vec3(10.f), Vec3(0.8f), 0.3f, BoundaryType::IndexMatched);
    auto err = [&](SceneDesc d, RenderOptions opt) {
        opt.spp = 1;
        Scene scene(std::move(d), 1);
        return error_of([&] { render(scene, opt); });
    };
    // Fine as it is.
    EXPECT_EQ(err(desc, st_options(models.path(), 2.f)), "");

    EXPECT_HAS(err(desc, st_options("", 2.f)),
               "needs the directory of the sphere-step models");
    EXPECT_HAS(err(desc, st_options(models.path() + "/nowhere", 2.f)),
               "nowhere: not a directory");
    EXPECT_HAS(err(desc, st_options(models.path(), -1.f)),
               "sphere_threshold must be a number >= 0");
    EXPECT_HAS(err(desc, st_options(models.path(), std::nanf(""))),
               "sphere_threshold must be a number >= 0");
    EXPECT_HAS(err(desc, st_options(models.path(), 0.25f)),
               "below the smallest optical radius");

    // A medium the models were not trained for takes no steps: "pt"'s image, bit for bit,
    // and a warning that names the shape, the value and the range.
    auto run = [&](SceneDesc d, RenderOptions opt) {
        opt.spp = 1;
        Scene scene(std::move(d), 1);
        return render(scene, opt);
    };
    auto said = [](const RenderResult& r) {
        std::string all;
        for (const std::string& w : r.warnings) all += w + "\n";
        return all;
    };
    auto untrained = [&](const SceneDesc& d, const RenderOptions& opt) {
        const RenderResult r = run(d, opt);
        RenderOptions pt = opt;
        pt.integrator = "pt";
        pt.step_nee = RenderOptions().step_nee;  // an option of "st" only
        EXPECT_EQ(r.total_sphere_steps, 0u);
        EXPECT_EQ(r.image, run(d, pt).image);
        EXPECT_HAS(said(r),
                   "shapes[0] ('sphere'): integrator 'st' takes no sphere steps");
        return said(r);
    };
    const RenderResult trained = run(desc, st_options(models.path(), 2.f));
    EXPECT_GT(trained.total_sphere_steps, 0u);
    EXPECT_EQ(said(trained), "");
    SceneDesc g = desc;
    g.shapes[0].medium.phase.x = 0.7f;  // Henyey-Greenstein's g
    EXPECT_EQ(err(g, st_options(models.path(), 2.f)), "");
    EXPECT_HAS(untrained(g, st_options(models.path(), 2.f)),
               "g = 0.7 is outside the training range [-0.5, 0.5]");

    // EventGen is needed (and the albedo checked against its range) only where steps
    // connect to lights: with StepNee::Event. Hits keeps its balls clear of point lights
    // instead.
    SceneDesc phi = desc;
    phi.shapes[0].medium.albedo = Vec3(0.8f, 0.95f, 0.8f);
    RenderOptions event = st_options(models.path(), 2.f);
    event.step_nee = StepNee::Event;
    EXPECT_HAS(untrained(phi, event), "albedo 0.95 is outside EventGen's training range");
    EXPECT_EQ(said(run(phi, st_options(models.path(), 2.f))),
              "");  // environment only: hits
    SceneDesc phi_point = sphere_scene(Vec3(10.f), Vec3(0.8f, 0.95f, 0.8f), 0.3f,
                                       BoundaryType::IndexMatched, true);
    EXPECT_HAS(untrained(phi_point, event),
               "albedo 0.95 is outside EventGen's training range");
    EXPECT_EQ(said(run(phi_point, st_options(models.path(), 2.f))), "");
    RenderOptions no_nee = st_options(models.path(), 2.f);
    no_nee.nee = false;  // EventGen is not used: any albedo
    EXPECT_EQ(err(phi, no_nee), "");
    // No NEE from inside a dielectric: EventGen unused.
    phi.shapes[0].boundary = test::boundary(BoundaryType::Dielectric);
    EXPECT_EQ(err(phi, event), "");
    phi.shapes[0].boundary = test::boundary(BoundaryType::IndexMatched);
    phi.shapes[0].medium.albedo = Vec3(0.9005f);  // within kPhiClampTolerance: clamped
    EXPECT_EQ(err(phi, event), "");

    RenderOptions bounces = st_options(models.path(), 2.f);
    bounces.max_bounces = 5;
    EXPECT_HAS(err(desc, bounces), "max_bounces 5 is not supported by integrator 'st'");

    test::ModelDir incomplete("incomplete");
    incomplete.write(random_decoder("LengthGen", 1));
    EXPECT_HAS(err(desc, st_options(incomplete.path(), 2.f)),
               "cannot open the model file");
}

#include "render/pt.h"

#include <gtest/gtest.h>

#include <cmath>

#include "render/renderer.h"
#include "testing/scenes.h"
#include "testing/stats.h"

using namespace sss;

namespace {

SceneDesc furnace_scene(Vec3 sigma_t, float g, BoundaryType boundary) {
    SceneDesc d = test::sphere_in_environment(sigma_t, Vec3(1.f), g, boundary);
    d.source = "furnace";
    return d;
}

// White furnace: no absorption inside a uniform environment of radiance 1, so every pixel
// has expectation 1 (or `expected`). Each pixel's mean is compared with it using its own
// estimated variance: per channel, the sum of z^2 over pixels must pass a chi-square test
// at p = 1e-4 and the image mean must be within 4 sigma of it. (Per channel: in a grey
// medium the three channels carry the same samples, and pooled they would not be
// independent terms.)
void expect_furnace(const SceneDesc& d, int spp, Vec3 expected = Vec3(1.f)) {
    Scene scene(d, 2);
    RenderOptions opt;
    opt.spp = spp;
    opt.seed = 3;
    RenderResult r = render(scene, opt);
    const size_t pixels = r.image.size() / 3;
    for (int c = 0; c < 3; ++c) {
        SCOPED_TRACE("channel " + std::to_string(c));
        double chi2 = 0, mean = 0, var_mean = 0;
        int n = 0;
        for (size_t p = 0; p < pixels; ++p) {
            const size_t i = 3 * p + c;
            ASSERT_TRUE(std::isfinite(r.image[i]));
            mean += r.image[i];
            var_mean += r.variance[i];
            if (r.variance[i] == 0.f) {  // background pixels see the environment directly
                EXPECT_FLOAT_EQ(r.image[i], expected[c]);
                continue;
            }
            chi2 +=
                (r.image[i] - expected[c]) * (r.image[i] - expected[c]) / r.variance[i];
            ++n;
        }
        mean /= pixels;
        const double se = std::sqrt(var_mean) / pixels;
        EXPECT_NEAR(mean, expected[c], 4.0 * se) << "image mean " << mean << " +- " << se;
        ASSERT_GT(n, 30);
        EXPECT_LT(chi2, sss::test::chi2_critical(n))
            << "chi2 " << chi2 << " over " << n << " pixels";
    }
}

}  // namespace

TEST(PathTracer, FurnaceGreyIndexMatched) {
    expect_furnace(furnace_scene(Vec3(4.f), 0.5f, BoundaryType::IndexMatched), 64);
}

TEST(PathTracer, FurnaceDenseIndexMatchedRoulettesMarchedShadowRays) {
    // Optically thick (40 mean free paths across the radius): most shadow rays to the
    // environment are sphere traced through the grid and rouletted on the transmittance
    // bound they reach, twice (docs/notation.md, "Shadow-ray Russian roulette"); a kept
    // ray that missed its weight would darken the furnace.
    expect_furnace(furnace_scene(Vec3(40.f), 0.f, BoundaryType::IndexMatched), 4096);
}

TEST(PathTracer, FurnaceChromaticIndexMatched) {
    // Different extinction per channel: flights sampled with a hero channel, all three
    // carried with spectral MIS.
    expect_furnace(furnace_scene(Vec3(1.f, 4.f, 10.f), -0.3f, BoundaryType::IndexMatched),
                   128);
}

// Spectral MIS: a chromatic medium's channel c must equal, in expectation, channel c of
// the same scene whose medium is grey with channel c's extinction (same albedo). Pixel by
// pixel, per channel, a chi-square test with both renders' variances, and the image means
// within 4 sigma. A camera ray that meets no medium carries all three channels at weight
// 1: its pixel is the environment exactly.
void expect_chromatic_matches_grey(BoundaryType boundary, int spp) {
    const Vec3 sigma_t(2.f, 6.f, 14.f), albedo(0.95f, 0.8f, 0.6f);
    RenderOptions opt;
    opt.spp = spp;
    opt.seed = 11;
    const SceneDesc chromatic =
        test::sphere_in_environment(sigma_t, albedo, 0.3f, boundary, true);
    const RenderResult c = render(Scene(chromatic, 2), opt);
    EXPECT_EQ(c.image[0], 1.f);  // the corner pixel sees the environment only
    EXPECT_EQ(c.variance[0], 0.f);
    for (int ch = 0; ch < 3; ++ch) {
        SCOPED_TRACE("channel " + std::to_string(ch));
        opt.seed = 100 + ch;
        const RenderResult g =
            render(Scene(test::sphere_in_environment(Vec3(sigma_t[ch]), albedo, 0.3f,
                                                     boundary, true),
                         2),
                   opt);
        double chi2 = 0, diff = 0, var = 0;
        int n = 0;
        for (size_t p = 0; p < c.image.size() / 3; ++p) {
            const size_t i = 3 * p + ch;
            ASSERT_TRUE(std::isfinite(c.image[i]));
            diff += c.image[i] - g.image[i];
            var += c.variance[i] + g.variance[i];
            if (c.variance[i] + g.variance[i] == 0.f) continue;
            chi2 += (c.image[i] - g.image[i]) * (c.image[i] - g.image[i]) /
                    (c.variance[i] + g.variance[i]);
            ++n;
        }
        EXPECT_NEAR(diff, 0.0, 4.0 * std::sqrt(var)) << "summed difference";
        ASSERT_GT(n, 30);
        EXPECT_LT(chi2, sss::test::chi2_critical(n)) << "chi2 " << chi2 << " over " << n;
    }
}

TEST(PathTracer, ChromaticChannelsMatchGreyMediaIndexMatched) {
    expect_chromatic_matches_grey(BoundaryType::IndexMatched, 64);
}

TEST(PathTracer, ChromaticChannelsMatchGreyMediaDielectric) {
    expect_chromatic_matches_grey(BoundaryType::Dielectric, 64);
}

TEST(PathTracer, FurnaceDielectricIsExactPerPath) {
    // Behind a dielectric there is no NEE and every escaping path carries weight exactly
    // 1: every pixel must be 1 up to float rounding, whatever the noise elsewhere.
    Scene scene(furnace_scene(Vec3(3.f), 0.7f, BoundaryType::Dielectric), 2);
    RenderOptions opt;
    opt.spp = 16;
    RenderResult r = render(scene, opt);
    for (float v : r.image) ASSERT_NEAR(v, 1.f, 1e-5f);
    double events = 0;
    for (float e : r.events) events += e;
    EXPECT_GT(events, 0.0);  // paths did enter the medium
}

// A diffuse floor of reflectance R (an open mesh of two triangles, at the render frame's
// y = 0) seen from above in a constant environment of radiance 1: every point of it sees
// the environment over its whole upper hemisphere and nothing else, so every pixel is R,
// with light sampling and MIS (a statistical test), and without (exact per path: one
// bounce of weight R, then the environment).
TEST(PathTracer, DiffuseFloorInAnEnvironmentReflectsItsReflectance) {
    SceneDesc d = test::sphere_in_environment(Vec3(1.f), Vec3(1.f), 0.f,
                                              BoundaryType::IndexMatched);
    d.source = "floor";
    d.shapes[0].mesh = make_open_mesh(
        {{-10.f, 0.f, -10.f}, {10.f, 0.f, -10.f}, {10.f, 0.f, 10.f}, {-10.f, 0.f, 10.f}},
        {{0, 2, 1}, {0, 3, 2}}, "floor");
    d.shapes[0].surface =
        parse_surface(R"({"type": "diffuse", "reflectance": [0.8, 0.5, 0.2]})");
    d.camera.origin = {0.3f, 2.f, 0.5f};
    d.camera.target = {0.f, 0.f, 0.f};
    expect_furnace(d, 32, Vec3(0.8f, 0.5f, 0.2f));
    Scene scene(d, 2);
    RenderOptions opt;
    opt.spp = 4;
    opt.nee = false;
    RenderResult r = render(scene, opt);
    for (size_t i = 0; i < r.image.size(); ++i)
        ASSERT_NEAR(r.image[i], Vec3(0.8f, 0.5f, 0.2f)[int(i % 3)], 1e-6f) << i;
}

TEST(PathTracer, AbsorbingSphereTransmitsBeerLambert) {
    // Albedo 0: a camera ray through the sphere's centre survives with e^{-sigma_t 2r}.
    SceneDesc d = furnace_scene(Vec3(0.5f), 0.f, BoundaryType::IndexMatched);
    d.shapes[0].medium.albedo = Vec3(0.f);
    d.shapes[0].mesh = make_icosphere({0, 0, 0}, 1.f, 6);
    d.camera.width = d.camera.height = 1;
    d.camera.fov = 1e-3f;  // one pixel, essentially one ray
    Scene scene(d, 1);
    RenderOptions opt;
    opt.spp = 20000;
    RenderResult r = render(scene, opt);
    double expected = std::exp(-0.5 * 2.0);
    double sd = std::sqrt(expected * (1 - expected) / opt.spp);
    EXPECT_NEAR(r.image[0], expected, 4 * sd);
}

TEST(Renderer, IdenticalForAnyThreadCount) {
    Scene scene(furnace_scene(Vec3(2.f, 3.f, 4.f), 0.2f, BoundaryType::Dielectric), 1);
    RenderOptions opt;
    opt.spp = 5;
    opt.threads = 1;
    RenderResult a = render(scene, opt);
    opt.threads = 3;
    RenderResult b = render(scene, opt);
    EXPECT_EQ(a.image, b.image);
    EXPECT_EQ(a.variance, b.variance);
    opt.seed = 1;
    RenderResult c = render(scene, opt);
    EXPECT_NE(a.image, c.image);
}

// The distance grid only saves work in pt: a flight skips its boundary ray, and a
// collision its query (the ball shrunk by the flight), only where the bound proves it
// stays inside, so the paths are the same whatever the grid. Behind a dielectric (no
// shadow rays, whose roulette reads the bound) the images are equal bit for bit, from a
// grid of 3 cells (almost every flight traces its ray), 48 and 160 (refined near the
// surface). A bound too large lets a flight pass the boundary: a different image, or
// paths that never end (seen with r_o - t / 2 and r_o + t / 2 for the shrunk ball).
// A photon whose state says it is in the medium while it is outside the mesh (a collision
// that lands on the surface, to the float, then a flight out from there, whose ray cannot
// see the crossing at its own origin) leaves the medium where a flight ends outside the
// distance grid, or passes back in where it meets the surface: either way it reaches the
// furnace's environment with weight 1. With albedo 1 it used to walk on for ever.
TEST(PathTracer, APhotonLeakedOutOfItsMeshStillEnds) {
    Scene scene(furnace_scene(Vec3(50.f), 0.9f, BoundaryType::IndexMatched), 2);
    const int max_bounces = 100000;
    const PathTracer pt(scene, max_bounces, /*nee=*/false);
    for (uint64_t seed = 0; seed < 32; ++seed) {
        PathState ps;
        pt.start(ps, Vec3(0.f, 0.f, 3.5f), Vec3(0.f, 0.f, -1.f), Rng(seed));
        ps.shape = 0;  // as after the leak: outside the unit sphere, heading away
        ps.o = Vec3(0.f, 0.f, 1.01f);
        ps.d = Vec3(0.f, 0.f, 1.f);
        while (!pt.advance(ps)) {
        }
        EXPECT_LT(ps.out.scatter_events, uint32_t(max_bounces)) << "seed " << seed;
        EXPECT_NEAR(ps.out.radiance.x, 1.f, 1e-5f) << "seed " << seed;
    }
}

TEST(PathTracer, TheGridOnlySavesWork) {
    SceneDesc d = furnace_scene(Vec3(40.f), 0.5f, BoundaryType::Dielectric);
    d.shapes[0].medium.albedo = Vec3(0.98f);
    d.camera.width = d.camera.height = 12;
    RenderOptions opt;
    opt.spp = 4;
    std::vector<float> first;
    for (int res : {3, 48, 160}) {
        d.render.grid_resolution = res;
        const RenderResult r = render(Scene(d, 2), opt);
        if (first.empty()) {
            first = r.image;
        } else {
            EXPECT_EQ(r.image, first) << "grid of " << res << " cells";
        }
    }
}

TEST(Renderer, StoppingKeepsWholePassesSoEveryPixelHasTheSameSamples) {
    Scene scene(furnace_scene(Vec3(20.f), 0.2f, BoundaryType::IndexMatched), 1);
    RenderOptions opt;
    opt.spp = 4096;
    opt.threads = 2;
    int calls = 0;
    RenderResult r = render(scene, opt, [&](double) { return ++calls < 3; });
    EXPECT_TRUE(r.cancelled);
    EXPECT_FALSE(r.time_limit_reached);
    EXPECT_LT(r.spp, opt.spp);
    for (size_t p = 0; p < r.samples.size(); ++p) {
        EXPECT_EQ(r.samples[p], uint32_t(r.spp));
        EXPECT_TRUE(std::isfinite(r.image[3 * p]));
    }
    EXPECT_EQ(r.total_paths, uint64_t(r.spp) * r.samples.size());

    // A time limit stops the same way, once the first pass is in.
    opt.time_limit = 0.2;
    opt.spp = 1 << 20;  // hours
    RenderResult t = render(scene, opt);
    EXPECT_TRUE(t.time_limit_reached);
    EXPECT_FALSE(t.cancelled);
    EXPECT_GE(t.spp, 1);
    EXPECT_LT(t.spp, opt.spp);
    for (uint32_t n : t.samples) EXPECT_EQ(n, uint32_t(t.spp));
}

// A render split by sample ranges (first_sample, keep_film: what sssphere.cluster runs on
// each node) adds up to the whole render: the same samples, so the same events exactly
// and the same sums up to their order of addition; and each part's path records are the
// whole render's for its samples.
TEST(RenderParts, SampleRangesAddUpToTheWholeRender) {
    Scene scene(test::sphere_in_environment(Vec3(8.f), Vec3(0.9f), 0.3f,
                                            BoundaryType::Dielectric, true),
                2);
    RenderOptions opt;
    opt.spp = 7;
    opt.seed = 11;
    opt.record_paths = true;
    const RenderResult whole = render(scene, opt);

    Film sum(whole.image.size() / 3);
    std::vector<uint32_t> events;
    for (auto [first, spp] : {std::pair{0, 3}, std::pair{3, 4}}) {
        RenderOptions part = opt;
        part.first_sample = first;
        part.spp = spp;
        part.keep_film = true;
        const RenderResult r = render(scene, part);
        ASSERT_EQ(r.film.pixels(), sum.pixels());
        sum.add(r.film);
        events.insert(events.end(), r.path_events.begin(), r.path_events.end());
    }
    RenderResult merged;
    sum.finish(opt.spp, merged);
    EXPECT_EQ(events, whole.path_events);
    EXPECT_EQ(merged.events, whole.events);
    EXPECT_EQ(merged.total_events, whole.total_events);
    for (size_t i = 0; i < whole.image.size(); ++i) {
        EXPECT_NEAR(merged.image[i], whole.image[i], 1e-6 * std::abs(whole.image[i]));
        EXPECT_NEAR(merged.variance[i], whole.variance[i],
                    1e-5 * std::abs(whole.variance[i]) + 1e-12);
    }

    RenderOptions beyond = opt;
    beyond.first_sample = (1 << 24) - 3;
    EXPECT_THROW(render(scene, beyond), Error);
}

// Bands of rows (first_row, rows) split a render by tiles too: each band's pixels are the
// whole render's, the other rows stay empty, and bands that do not fit are refused.
TEST(RenderParts, BandsOfRowsAddUpToTheWholeRender) {
    Scene scene(test::sphere_in_environment(Vec3(8.f), Vec3(0.9f), 0.3f,
                                            BoundaryType::Dielectric),
                2);
    RenderOptions opt;
    opt.spp = 5;
    opt.seed = 2;
    const RenderResult whole = render(scene, opt);
    const int W = scene.desc().camera.width, H = scene.desc().camera.height;

    Film sum(size_t(W) * H);
    for (auto [first, rows] : {std::pair{0, 5}, std::pair{5, H - 5}}) {
        RenderOptions part = opt;
        part.first_row = first;
        part.rows = rows;
        part.keep_film = true;
        const RenderResult r = render(scene, part);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x)
                if (y < first || y >= first + rows) {
                    ASSERT_EQ(r.film.event_counts()[size_t(y) * W + x], 0u)
                        << x << "," << y;
                }
        sum.add(r.film);
    }
    RenderResult merged;
    sum.finish(opt.spp, merged);
    EXPECT_EQ(merged.events, whole.events);
    EXPECT_EQ(merged.image, whole.image);  // each pixel's sums are the whole render's

    RenderOptions bad = opt;
    bad.first_row = H - 2;
    bad.rows = 3;
    EXPECT_THROW(render(scene, bad), Error);
}

#include "render/options.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "render/scene.h"
#include "testing/errors.h"

namespace sss {
namespace {

using test::error_of;

RenderOptions resolve(const RenderSettings& scene, const RenderOverrides& o) {
    return resolve_render_options(scene, "s.json", o, "shipped/");
}

TEST(RenderOptions, DefaultsThenSceneThenOverrides) {
    RenderSettings scene;  // the scene file said nothing
    RenderOptions d = resolve(scene, {});
    const RenderOptions defaults;
    EXPECT_EQ(d.integrator, defaults.integrator);
    EXPECT_EQ(d.spp, defaults.spp);
    EXPECT_EQ(d.sphere_threshold, kDefaultSphereThreshold);
    EXPECT_EQ(d.models, "shipped/");
    EXPECT_TRUE(d.nee);
    EXPECT_EQ(d.backend, Backend::Cpu);

    scene.integrator = "st";
    scene.spp = 64;
    scene.seed = 7;
    scene.sphere_threshold = 3.f;
    scene.models = "scene-models/";
    RenderOptions s = resolve(scene, {});
    EXPECT_EQ(s.integrator, "st");
    EXPECT_EQ(s.spp, 64);
    EXPECT_EQ(s.seed, 7u);
    EXPECT_EQ(s.sphere_threshold, 3.f);
    EXPECT_EQ(s.models, "scene-models/");

    RenderOverrides o;
    o.integrator = "pt";
    o.spp = 5;
    o.nee = false;
    o.backend = "vulkan";
    RenderOptions r = resolve(scene, o);
    EXPECT_EQ(r.integrator, "pt");
    EXPECT_EQ(r.spp, 5);
    EXPECT_EQ(r.seed, 7u);  // not overridden: the scene's
    EXPECT_FALSE(r.nee);
    EXPECT_EQ(r.backend, Backend::Vulkan);

    o.integrator = "st";
    o.models = "mine/";
    EXPECT_EQ(resolve(scene, o).models, "mine/");
}

TEST(RenderOptions, OptionsOfStGivenWithAnotherIntegratorAreRefused) {
    // The scene file's models and threshold are taken whatever the integrator; the same
    // given by the caller with "pt" would change nothing, and are refused.
    RenderSettings scene;
    scene.models = "scene-models/";
    scene.sphere_threshold = 3.f;
    EXPECT_EQ(resolve(scene, {}).integrator, "pt");
    RenderOverrides o;
    o.models = "mine/";
    EXPECT_HAS(error_of([&] { resolve(scene, o); }),
               "models is an option of integrator 'st' (the integrator is 'pt')");
    o = {};
    o.sphere_threshold = 2.0;
    EXPECT_HAS(error_of([&] { resolve(scene, o); }),
               "sphere_threshold is an option of integrator 'st'");
    o.integrator = "st";
    EXPECT_EQ(resolve(scene, o).sphere_threshold, 2.f);
}

TEST(RenderOptions, ATimeLimitWithoutSppLeavesTheTimeToEndTheRender) {
    RenderSettings scene;
    RenderOverrides o;
    o.time_limit = 2.5;
    RenderOptions r = resolve(scene, o);
    EXPECT_EQ(r.time_limit, 2.5);
    EXPECT_EQ(r.spp, render_option_spec("spp").hi);  // no spp given: unlimited
    scene.spp = 64;                                  // an spp given stays the most
    EXPECT_EQ(resolve(scene, o).spp, 64);
    o.spp = 8;
    EXPECT_EQ(resolve(scene, o).spp, 8);
    scene.time_limit = 9.0;  // the scene's limit, overridden by the caller's
    EXPECT_EQ(resolve(scene, {}).time_limit, 9.0);
    EXPECT_EQ(resolve(scene, o).time_limit, 2.5);
    for (double bad : {-1.0, 2e9, double(INFINITY), double(NAN)}) {
        o.time_limit = bad;
        EXPECT_NE(
            error_of([&] {
                resolve(scene, o);
            }).find("time_limit must be a number from 0 to 1e9 (seconds; 0: no limit)"),
            std::string::npos);
    }
}

TEST(RenderOptions, BadValuesNameTheOptionAndWhatIsAllowed) {
    RenderSettings scene;
    auto err = [&](auto set) {
        RenderOverrides o;
        set(o);
        return error_of([&] { resolve(scene, o); });
    };
    EXPECT_HAS(err([](auto& o) { o.spp = 0; }), "spp must be an integer >= 1");
    EXPECT_HAS(err([](auto& o) { o.seed = -1; }),
               "seed must be an integer from 0 to 2^63 - 1, got -1");
    EXPECT_HAS(err([](auto& o) { o.threads = -2; }),
               "threads must be an integer from 0 to 4096");
    EXPECT_HAS(err([](auto& o) { o.threads = 4097; }),
               "threads must be an integer from 0 to 4096");
    EXPECT_HAS(err([](auto& o) { o.max_bounces = -3; }),
               "max_bounces must be an integer from -1 (no limit) to 2147483647");
    EXPECT_HAS(err([](auto& o) { o.integrator = "mc"; }),
               "integrator 'mc' is not allowed (allowed: 'pt', 'st')");
    EXPECT_HAS(err([](auto& o) { o.step_nee = "paper"; }),
               "step_nee 'paper' is not allowed (allowed: 'hits', 'event')");
    EXPECT_HAS(err([](auto& o) { o.sphere_threshold = -1.0; }),
               "sphere_threshold must be a number >= 0");
    EXPECT_HAS(err([](auto& o) { o.sphere_threshold = std::nan(""); }),
               "sphere_threshold must be a number >= 0");
    EXPECT_HAS(err([](auto& o) { o.integrator = "st", o.max_bounces = 3; }),
               "s.json: max_bounces 3 is not supported by integrator 'st' (allowed: -1)");
    EXPECT_HAS(err([](auto& o) { o.backend = "vulkan", o.threads = 2; }),
               "threads=2 is CPU-only");
    EXPECT_HAS(err([](auto& o) {
                   o.integrator = "st", o.backend = "vulkan", o.step_nee = "event";
               }),
               "step_nee 'event' is CPU-only");
    EXPECT_HAS(err([](auto& o) { o.backend = "cuda"; }),
               "backend 'cuda' is not allowed (allowed: 'cpu', 'vulkan')");
    // Options of "st" given to "pt": refused (they would change nothing).
    EXPECT_HAS(
        err([](auto& o) { o.integrator = "pt", o.step_nee = "event"; }),
        "s.json: step_nee 'event' is an option of integrator 'st' (the integrator is "
        "'pt')");
    EXPECT_HAS(err([](auto& o) { o.integrator = "pt", o.sphere_sampler = "walk"; }),
               "sphere_sampler 'walk' is an option of integrator 'st'");
    // ... on either backend: not "CPU-only", which said they would work on the CPU
    EXPECT_HAS(err([](auto& o) {
                   o.integrator = "pt", o.backend = "vulkan", o.step_nee = "event";
               }),
               "step_nee 'event' is an option of integrator 'st'");
    EXPECT_HAS(err([](auto& o) {
                   o.integrator = "pt", o.backend = "vulkan", o.sphere_sampler = "walk";
               }),
               "sphere_sampler 'walk' is an option of integrator 'st'");
    EXPECT_EQ(err([](auto& o) { o.integrator = "pt", o.step_nee = "hits"; }), "");
    EXPECT_EQ(err([](auto& o) { o.integrator = "st", o.step_nee = "event"; }), "");
}

TEST(RenderOptions, CommandLineTextIsParsedAndChecked) {
    RenderOverrides o;
    set_override_from_text(o, "spp", "12");
    set_override_from_text(o, "sphere_threshold", "inf");
    set_override_from_text(o, "nee", "false");
    set_override_from_text(o, "step_nee", "event");
    set_override_from_text(o, "integrator", "st");
    RenderOptions r = resolve(RenderSettings(), o);
    EXPECT_EQ(r.spp, 12);
    EXPECT_TRUE(std::isinf(r.sphere_threshold));
    EXPECT_FALSE(r.nee);
    EXPECT_EQ(r.step_nee, StepNee::Event);
    EXPECT_HAS(error_of([&] { set_override_from_text(o, "spp", "1.5"); }),
               "--spp: expected an integer >= 1");
    EXPECT_HAS(
        error_of([&] { set_override_from_text(o, "seed", "99999999999999999999"); }),
        "--seed: expected an integer from 0 to 2^63 - 1");
    EXPECT_HAS(error_of([&] { set_override_from_text(o, "sphere_threshold", "nan"); }),
               "--sphere-threshold: expected a number >= 0");
    EXPECT_HAS(error_of([&] { set_override_from_text(o, "colour", "red"); }),
               "unknown render option 'colour' (allowed: integrator, spp");
}

TEST(RenderOptions, TheTableNamesEveryOptionOnce) {
    std::set<std::string> names;
    for (const OptionSpec& s : render_option_specs()) {
        EXPECT_TRUE(names.insert(s.name).second) << s.name;
        EXPECT_NE(std::string(s.help), "") << s.name;
        EXPECT_NE(std::string(s.allowed), "") << s.name;
        EXPECT_EQ(s.kind == OptionSpec::Kind::Choice, !s.choices.empty()) << s.name;
        if (s.kind == OptionSpec::Kind::Integer) {
            EXPECT_LT(s.lo, s.hi) << s.name;
        }
    }
}

}  // namespace
}  // namespace sss

#include "render/scene.h"

#include <gtest/gtest.h>

#include "core/check.h"
#include "io/json_fields.h"
#include "render/medium_presets.h"
#include "testing/scenes.h"

using namespace sss;

namespace {

const char* kGood = R"({
  "camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 30, "width": 8, "height": 6},
  "shapes": [{"sphere": {"center": [0, 0, 0], "radius": 1},
              "medium": {"sigma_t": [1, 2, 3], "albedo": 0.9, "g": 0.3}}],
  "lights": [{"type": "point", "position": [2, 2, 2], "intensity": 5}],
  "render": {"spp": 4, "seed": 9}
})";

// Parses kGood with `from` replaced by `to`; returns the error message ("" if none).
std::string error_with(const std::string& from, const std::string& to) {
    std::string text = kGood;
    size_t pos = text.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    text.replace(pos, from.size(), to);
    try {
        parse_scene(text, ".", "test.json");
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(SceneParse, GoodSceneAndDefaults) {
    SceneDesc d = parse_scene(kGood, ".", "test.json");
    EXPECT_EQ(d.camera.width, 8);
    EXPECT_EQ(d.shapes.size(), 1u);
    EXPECT_EQ(d.shapes[0].medium.albedo, Vec3(0.9f));
    EXPECT_STREQ(d.shapes[0].boundary.kind().name, "index_matched");
    EXPECT_EQ(d.render.spp, 4);
    EXPECT_EQ(d.render.max_bounces, -1);
    EXPECT_EQ(d.render.integrator, "pt");
}

struct BadCase {
    std::string from, to, expect1, expect2;
    friend void PrintTo(const BadCase& c, std::ostream* os) { *os << c.to; }
};

class SceneParseErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(SceneParseErrors, NameFieldAndProblem) {
    const BadCase& c = GetParam();
    std::string e = error_with(c.from, c.to);
    EXPECT_NE(e.find("test.json"), std::string::npos) << e;
    EXPECT_NE(e.find(c.expect1), std::string::npos) << e;
    EXPECT_NE(e.find(c.expect2), std::string::npos) << e;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, SceneParseErrors,
    ::testing::Values(
        BadCase{"\"fov\": 30", "\"fov\": 30, \"zoom\": 2", "camera.zoom", "unknown key"},
        BadCase{"\"albedo\": 0.9", "\"albedo\": [0.5, 1.2, 0.5]",
                "shapes[0].medium.albedo", "[0, 1]"},
        BadCase{"\"sigma_t\": [1, 2, 3]", "\"sigma_t\": [1, -2, 3]",
                "shapes[0].medium.sigma_t", "[1,-2,3]"},
        BadCase{"\"g\": 0.3", "\"g\": 1.0", "shapes[0].medium.g", "-1 < g < 1"},
        BadCase{"\"spp\": 4", "\"spp\": 0", "render.spp", "1 to"},
        BadCase{"\"width\": 8", "\"width\": 100000", "camera.width", "1 to 16384"},
        BadCase{"\"width\": 8", "\"width\": 8.5", "camera.width", "integer"},
        BadCase{"\"radius\": 1", "\"radius\": \"big\"", "sphere.radius",
                "expected a number"},
        BadCase{"\"radius\": 1", "\"radius\": 1e999",
                "malformed JSON at shapes[0].sphere.radius", "1e999"},
        BadCase{"\"radius\": 1", "\"radius\": NaN", "malformed JSON",
                "NaN and Infinity are not JSON numbers"},
        BadCase{"\"type\": \"point\"", "\"type\": \"spot\"", "lights[0].type",
                "\"point\""},
        BadCase{"\"seed\": 9", "\"seed\": 9,", "malformed JSON", "parse"},
        BadCase{"\"target\": [0, 0, 0]", "\"target\": [0, 0, 4]", "camera.target",
                "equals origin"},
        BadCase{"\"sphere\": {\"center\": [0, 0, 0], \"radius\": 1}",
                "\"mesh\": \"no_such.obj\"", "shapes[0].mesh", "does not exist"}));

// The parser quotes the bytes it stopped at: a file that starts with two byte-order marks
// (the second, after the first is skipped, an invalid literal) put a lone 0xEF byte, not
// UTF-8, into the message and so onto stderr.
TEST(SceneParse, MessagesAreUtf8WhateverTheFileHolds) {
    std::string e;
    try {
        parse_scene("\xEF\xBB\xBF\xEF\xBB\xBF{}", ".", "test.json");
    } catch (const Error& err) {
        e = err.what();
    }
    EXPECT_NE(e.find("malformed JSON"), std::string::npos) << e;
    EXPECT_NE(e.find("\\xef"), std::string::npos) << e;
    EXPECT_EQ(json_fields::utf8_or_escaped("ok \xC3\xA9 \xF0\x9F\x99\x82"),
              "ok \xC3\xA9 \xF0\x9F\x99\x82");
    EXPECT_EQ(json_fields::utf8_or_escaped("\xEF\xBB"), "\\xef\\xbb");  // cut short
    EXPECT_EQ(json_fields::utf8_or_escaped("\xC0\x80 \xED\xA0\x80"),
              "\\xc0\\x80 \\xed\\xa0\\x80");  // overlong, surrogate
    EXPECT_EQ(json_fields::utf8_or_escaped("\xFF"), "\\xff");
}

TEST(SceneBuild, RefusesCameraInsideShape) {
    std::string text = kGood;
    text.replace(text.find("[0, 0, 4]"), 9, "[0, 0, 0.2]");
    text.replace(text.find("\"target\": [0, 0, 0]"), 19, "\"target\": [0, 0, 1]");
    try {
        Scene s(parse_scene(text, ".", "test.json"), 1);
        FAIL() << "camera inside a shape was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("inside shape"), std::string::npos)
            << e.what();
    }
}

// Without grid_resolution each shape's grid has 64 cells along its largest side, 128
// when such a cell is more than kGridCellMeanFreePaths mean free paths thick, and 256
// past kFineGridCellMeanFreePaths; 16 or 32 when so few cover it at a mean free path
// each.
TEST(Scene, GridResolutionFollowsTheDensestChannelWhenUnset) {
    const float side = 2.f;  // the unit sphere's diameter (the icosphere spans it)
    const float dense = Scene::kGridCellMeanFreePaths * 64.f / side * 1.5f;
    const float denser = Scene::kFineGridCellMeanFreePaths * 64.f / side * 1.5f;
    // optically small: one cell per mean free path is enough (16 or 32 cells)
    const float thin16 = 16.f / side * Scene::kCoarseGridCellMeanFreePaths,
                thin32 = 32.f / side * Scene::kCoarseGridCellMeanFreePaths;
    for (float sigma_max : {thin16, thin32, thin32 * 1.01f, dense / 3.f, dense, denser}) {
        SceneDesc d = test::sphere_in_environment(Vec3(1.f, sigma_max, 2.f), Vec3(0.9f),
                                                  0.f, BoundaryType::IndexMatched);
        d.render.grid_resolution = 0;
        Scene scene(d, 2);
        const int cells = sigma_max == denser   ? 256
                          : sigma_max == dense  ? 128
                          : sigma_max == thin16 ? 16
                          : sigma_max == thin32 ? 32
                                                : 64;
        EXPECT_NEAR(scene.grid(0).cell_size(), side / float(cells), 1e-4f)
            << "sigma_t " << sigma_max;
    }
    SceneDesc d = test::sphere_in_environment(Vec3(1.f, dense, 2.f), Vec3(0.9f), 0.f,
                                              BoundaryType::IndexMatched);
    d.render.grid_resolution = 16;  // set: kept
    EXPECT_NEAR(Scene(d, 2).grid(0).cell_size(), side / 16.f, 1e-4f);
}

// The camera check takes the bounds and the grid's sign before the exact test: a camera
// inside the bounds but outside the mesh (a corner of the sphere's box), and one just
// inside the surface (within a grid cell, where only the exact test can tell).
// kGood with a coarser sphere (1,280 triangles): quick to build grids for.
std::string coarse_good() {
    std::string text = kGood;
    text.replace(text.find("\"radius\": 1}"), 12, "\"radius\": 1, \"subdivisions\": 3}");
    return text;
}

TEST(SceneBuild, CameraCheckIsExactNearTheSurface) {
    for (const char* origin : {"[0.7, 0.7, 0.2]", "[0, 0, 0.99]"}) {
        std::string text = coarse_good();
        text.replace(text.find("[0, 0, 4]"), 9, origin);
        text.replace(text.find("\"target\": [0, 0, 0]"), 19, "\"target\": [0, 0, 5]");
        const bool inside = std::string(origin) == "[0, 0, 0.99]";
        try {
            Scene s(parse_scene(text, ".", "test.json"), 2);
            EXPECT_FALSE(inside) << origin << " is inside the sphere";
        } catch (const Error& e) {
            EXPECT_TRUE(inside) << origin << ": " << e.what();
        }
    }
}

// An edited scene keeps the BVH and the grids whose meshes did not change.
TEST(SceneBuild, AnEditKeepsWhatItDidNotChange) {
    const Scene first(parse_scene(coarse_good(), ".", "test.json"), 2);
    SceneDesc edited = parse_scene(coarse_good(), ".", "test.json");
    edited.shapes[0].medium.albedo = Vec3(0.5f);
    edited.camera.fov = 20.f;
    const Scene second(std::move(edited), 2, first);
    EXPECT_EQ(&second.tracer(), &first.tracer());
    EXPECT_EQ(&second.grid(0), &first.grid(0));
    EXPECT_TRUE(second.rebuilt().empty());
    SceneDesc moved = parse_scene(coarse_good(), ".", "test.json");
    for (Vec3& p : moved.shapes[0].mesh.positions) p = p * 0.5f;
    const Scene third(std::move(moved), 2, second);
    EXPECT_NE(&third.tracer(), &second.tracer());
    EXPECT_NE(&third.grid(0), &second.grid(0));
    ASSERT_EQ(third.rebuilt().size(), 2u);
    EXPECT_EQ(third.rebuilt()[0], "BVH");
}

// The albedo AOV's forward fit undoes the `color` inversion (Chiang et al. 2016).
TEST(MediumPresets, MultipleScatteringAlbedoInvertsTheColorFit) {
    for (float color = 0.02f; color < 0.995f; color += 0.0313f) {
        const ReducedCoefficients r =
            invert_multiple_scattering_albedo(Vec3(color), Vec3(1.f));
        const float reduced_albedo =
            r.sigma_s_prime.x / (r.sigma_s_prime.x + r.sigma_a.x);
        EXPECT_NEAR(multiple_scattering_albedo(reduced_albedo), color, 2e-5f) << color;
    }
    EXPECT_EQ(multiple_scattering_albedo(0.f), 0.f);
    EXPECT_EQ(multiple_scattering_albedo(1.f), 1.f);
}

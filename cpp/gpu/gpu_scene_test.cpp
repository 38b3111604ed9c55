#include "gpu/gpu_scene.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include "testing/errors.h"

namespace sss {
namespace {

using test::error_of;

std::string temp_path(const char* name) { return (::testing::TempDir() + "/") + name; }

// save_gpu_scene then load_gpu_scene gives back every byte of the header and the arrays.
TEST(GpuScene, FileRoundTrip) {
    GpuSceneData s;
    s.source = "scene.json";
    s.header.counts[0] = 1;
    s.header.lighting[0] = 2;
    s.header.lighting[1] = 1;
    s.header.lights[1].a[3] = 3.f;
    s.header.lights[1].value[2] = 0.25f;
    s.nodes.resize(3);
    s.nodes[2].child[1] = 7;
    s.triangles.resize(2);
    s.triangles[1].mesh = 4;
    s.floats = {0.5f, 1.5f};
    s.model = {1.f, 2.f, 3.f};
    s.cut_model = {4.f, 5.f};
    s.header.cut_grids[3].n[3] = 9;
    const std::string path = temp_path("round_trip.bin");
    save_gpu_scene(s, path);
    const GpuSceneData t = load_gpu_scene(path);
    EXPECT_EQ(t.source, s.source);
    EXPECT_EQ(std::memcmp(&t.header, &s.header, sizeof(s.header)), 0);
    ASSERT_EQ(t.nodes.size(), 3u);
    EXPECT_EQ(t.nodes[2].child[1], 7u);
    ASSERT_EQ(t.triangles.size(), 2u);
    EXPECT_EQ(t.triangles[1].mesh, 4u);
    EXPECT_EQ(t.floats, s.floats);
    EXPECT_EQ(t.model, s.model);
    EXPECT_EQ(t.cut_model, s.cut_model);
    std::remove(path.c_str());
}

// Files baked by earlier versions (magic SSSGPU01 to SSSGPU07) have other layouts:
// refused with the way out; any other file is not a baked scene.
TEST(GpuScene, OldAndForeignFilesAreRefused) {
    const std::string old_file = temp_path("old.bin"), other = temp_path("other.bin");
    std::ofstream(other, std::ios::binary) << "{\"camera\": {}}";
    for (const char* magic : {"SSSGPU01", "SSSGPU02", "SSSGPU03", "SSSGPU04", "SSSGPU05",
                              "SSSGPU06", "SSSGPU07"}) {
        std::ofstream(old_file, std::ios::binary) << magic << " and whatever followed";
        const std::string old_msg = error_of([&] { load_gpu_scene(old_file); });
        EXPECT_HAS(old_msg, old_file);
        EXPECT_HAS(old_msg, magic);
        EXPECT_HAS(old_msg, "bake the scene again");
    }
    EXPECT_HAS(error_of([&] { load_gpu_scene(other); }),
               "not a baked GPU scene (no SSSGPU08 header)");
    EXPECT_HAS(error_of([&] { load_gpu_scene(temp_path("missing.bin")); }),
               "baked scene file does not exist");
    std::remove(old_file.c_str());
    std::remove(other.c_str());
}

}  // namespace
}  // namespace sss

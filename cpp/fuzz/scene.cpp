// Fuzz target for the scene parser: parse_scene on the input text, with mesh paths
// relative to the scratch directory, which holds two small closed meshes (cube.obj and
// tetra.off, the names the seed scenes use) so that a scene can name a mesh that loads.
#include "render/scene.h"

#include <cstring>

#include "fuzz/fuzz.h"

namespace sss::fuzz {

namespace {

constexpr const char* kCubeObj =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\n"
    "v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
constexpr const char* kTetraOff =
    "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
    "3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n";

const std::string& base_dir() {
    static const std::string dir = [] {
        for (const auto& [name, text] :
             {std::pair{"cube.obj", kCubeObj}, std::pair{"tetra.off", kTetraOff}})
            write_scratch_file(name, reinterpret_cast<const uint8_t*>(text),
                               std::strlen(text));
        return scratch_dir().string();
    }();
    return dir;
}

}  // namespace

int fuzz_scene(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    return guarded([&] { parse_scene(text, base_dir(), "fuzz.json"); });
}

}  // namespace sss::fuzz

// Fuzz targets for the mesh readers: load_mesh picks the reader by the file's extension,
// so each format's target writes the input to a file of that extension. The PLY and STL
// readers tell ASCII from binary by the content, so one target each covers both.
#include "geometry/mesh.h"

#include "fuzz/fuzz.h"

namespace sss::fuzz {

namespace {

int fuzz_mesh(const char* file_name, const uint8_t* data, size_t size) {
    const std::string path = write_scratch_file(file_name, data, size);
    return guarded([&] { load_mesh(path); });
}

}  // namespace

int fuzz_mesh_obj(const uint8_t* data, size_t size) {
    return fuzz_mesh("input.obj", data, size);
}
int fuzz_mesh_ply(const uint8_t* data, size_t size) {
    return fuzz_mesh("input.ply", data, size);
}
int fuzz_mesh_off(const uint8_t* data, size_t size) {
    return fuzz_mesh("input.off", data, size);
}
int fuzz_mesh_stl(const uint8_t* data, size_t size) {
    return fuzz_mesh("input.stl", data, size);
}

}  // namespace sss::fuzz

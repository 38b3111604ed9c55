// Fuzz targets for read_image (OpenImageIO picks the reader by the file's extension and
// content): the input is written to a .exr or .png file.
#include "fuzz/fuzz.h"
#include "io/image_io.h"

namespace sss::fuzz {

namespace {

int fuzz_image(const char* file_name, const uint8_t* data, size_t size) {
    const std::string path = write_scratch_file(file_name, data, size);
    return guarded([&] {
        int width = 0, height = 0, channels = 0;
        read_image(path, &width, &height, &channels);
    });
}

}  // namespace

int fuzz_image_exr(const uint8_t* data, size_t size) {
    return fuzz_image("input.exr", data, size);
}
int fuzz_image_png(const uint8_t* data, size_t size) {
    return fuzz_image("input.png", data, size);
}

}  // namespace sss::fuzz

// Image output with OpenImageIO: .exr keeps linear float radiance; .png is 8-bit sRGB
// (the linear values clamped to [0, 1], then the sRGB transfer curve).
#pragma once

#include <string>
#include <vector>

namespace sss {

// Throws sss::Error unless `path` can be an output image: a .exr or .png name in an
// existing directory (checked before a render, not after it).
void check_output_image(const std::string& path);

// `pixels` holds height * width * channels floats, row 0 at the top.
void write_image(const std::string& path, const std::vector<float>& pixels, int width,
                 int height, int channels = 3);

// Reads an image as float (height * width * channels, row 0 at the top); 8-bit files give
// their stored values / 255 (no colour conversion).
std::vector<float> read_image(const std::string& path, int* width, int* height,
                              int* channels);

// Makes read_image the scene parser's image reader (io/image_input.h).
void install_image_reader();

// sRGB encoding of a linear value, clamped to [0, 1].
float linear_to_srgb(float v);

}  // namespace sss

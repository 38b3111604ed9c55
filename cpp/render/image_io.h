// Image output with OpenImageIO: .exr keeps linear float radiance; .png is 8-bit sRGB
// (the linear values clamped to [0, 1], then the sRGB transfer curve).
#pragma once

#include <string>
#include <vector>

namespace sss {

// `pixels` holds height * width * channels floats, row 0 at the top.
void write_image(const std::string& path, const std::vector<float>& pixels, int width, int height,
                 int channels = 3);

// sRGB encoding of a linear value, clamped to [0, 1].
float linear_to_srgb(float v);

}  // namespace sss

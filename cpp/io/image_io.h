// Image output with OpenImageIO: .exr keeps linear float radiance; .png is 8-bit sRGB
// (the linear values clamped to [0, 1], then the sRGB transfer curve).
#pragma once

#include <string>
#include <vector>

namespace sss {

// Throws sss::Error unless `path` can be an output image: a .exr or .png name, not a
// directory, in an existing directory where a file can be created (checked before a
// render, not after it).
void check_output_image(const std::string& path);

// Throws sss::Error if `path` names one of `inputs` (the files a scene reads) or a link
// to one: writing it would overwrite what the scene is made of.
void check_output_is_not_an_input(const std::string& path,
                                  const std::vector<std::string>& inputs);

// The file an image written to `path` replaces: `path`, or where its symbolic links lead
// (an output through a link replaces the link's target, not the link).
std::string output_target(const std::string& path);

// `pixels` holds height * width * channels floats, row 0 at the top.
void write_image(const std::string& path, const std::vector<float>& pixels, int width,
                 int height, int channels = 3);

// A multilayer EXR holds at most this many channels (our AOVs need 15).
constexpr int kMaxLayeredChannels = 32;

// One layer of a multilayer EXR: its channels are named LAYER.CHANNEL (CHANNEL alone for
// the unnamed layer, which viewers show); `data` holds height * width * channels floats.
struct ImageLayer {
    std::string name;
    std::vector<std::string> channels;
    std::vector<float> data;
};

// One .exr file of all the layers, float, channels in the order given.
void write_exr_layers(const std::string& path, int width, int height,
                      const std::vector<ImageLayer>& layers);

// Every channel of an .exr file (1 to kMaxLayeredChannels), interleaved, and their names.
std::vector<float> read_exr_layers(const std::string& path, int* width, int* height,
                                   std::vector<std::string>* channel_names);

// Reads an image as float (height * width * channels, row 0 at the top); 8-bit files give
// their stored values / 255 (no colour conversion).
std::vector<float> read_image(const std::string& path, int* width, int* height,
                              int* channels);

// Makes read_image the scene parser's image reader (io/image_input.h).
void install_image_reader();

// sRGB encoding of a linear value, clamped to [0, 1].
float linear_to_srgb(float v);

}  // namespace sss

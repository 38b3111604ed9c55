// How the scene parser reads images (environment maps). The renderer's libraries link no
// image library, so that the Python module _core stays free of OpenImageIO
// (docs/architecture.md): the program that has one installs a reader here once, before it
// loads scenes. sssphere-render, sssphere-gpu-bench and the C++ tests install
// sss::read_image (io/image_io.h); the Python module _core one that calls
// sssphere._image.read_image.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace sss {

// height * width * channels floats, row 0 at the top, linear as stored in the file.
struct ImageData {
    std::vector<float> pixels;
    int width = 0, height = 0, channels = 0;
};

using ImageReader = std::function<ImageData(const std::string& path)>;

// The installed reader (empty until a program installs one).
inline ImageReader& image_reader() {
    static ImageReader reader;
    return reader;
}

}  // namespace sss

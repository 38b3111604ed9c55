#include "io/image_io.h"

#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "core/check.h"
#include "core/files.h"

namespace sss {

float linear_to_srgb(float v) {
    v = std::clamp(std::isfinite(v) ? v : 0.f, 0.f, 1.f);
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

void check_output_image(const std::string& path) {
    namespace fs = std::filesystem;
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext != ".exr" && ext != ".png")
        fail(path, ": unsupported image format '", ext, "' (allowed: .exr, .png)");
    fs::path parent = fs::path(path).parent_path();
    if (!parent.empty() && !fs::is_directory(parent))
        fail(path, ": output directory '", parent.string(), "' does not exist");
}

void write_image(const std::string& path, const std::vector<float>& pixels, int width,
                 int height, int channels) {
    namespace fs = std::filesystem;
    check_output_image(path);
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    SSS_CHECK(pixels.size() == size_t(width) * height * channels);

    // Written to a temporary file beside it (same extension: it picks the format), then
    // renamed into place: an interrupted or failed write never leaves a truncated image
    // where the previous one was.
    const fs::path target(path);
    const std::string tmp = (target.parent_path() /
                             ("." + target.stem().string() + ".tmp-" +
                              std::to_string(::getpid()) + target.extension().string()))
                                .string();
    auto cleanup = [&] {
        std::error_code ec;
        fs::remove(tmp, ec);
    };
    auto out = OIIO::ImageOutput::create(path);
    if (!out) fail(path, ": cannot create an image writer: ", OIIO::geterror());
    bool ok;
    if (ext == ".exr") {
        OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::FLOAT);
        spec.attribute("compression", "zip");
        ok = out->open(tmp, spec) &&
             out->write_image(OIIO::TypeDesc::FLOAT, pixels.data());
    } else {
        std::vector<unsigned char> bytes(pixels.size());
        for (size_t i = 0; i < pixels.size(); ++i)
            bytes[i] = (unsigned char)std::lround(255.f * linear_to_srgb(pixels[i]));
        OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
        spec.attribute("oiio:ColorSpace", "sRGB");
        ok =
            out->open(tmp, spec) && out->write_image(OIIO::TypeDesc::UINT8, bytes.data());
    }
    if (!ok) {
        const std::string why = out->geterror();
        cleanup();
        fail(path, ": cannot write image: ", why);
    }
    if (!out->close()) {
        const std::string why = out->geterror();
        cleanup();
        fail(path, ": cannot finish writing image: ", why);
    }
    std::error_code ec;
    fs::rename(tmp, target, ec);
    if (ec) {
        cleanup();
        fail(path, ": cannot move the written image into place: ", ec.message());
    }
}

std::vector<float> read_image(const std::string& path, int* width, int* height,
                              int* channels) {
    check_input_file(path, "image file");
    auto in = OIIO::ImageInput::open(path);
    if (!in) fail(path, ": cannot read image: ", OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    *width = spec.width;
    *height = spec.height;
    *channels = spec.nchannels;
    // A header may claim any size: refuse what no image of ours needs before allocating
    // (found by fuzzing: an EXR of a few bytes asked for gigabytes).
    const int64_t pixels = int64_t(spec.width) * int64_t(spec.height);
    if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1 || spec.nchannels > 4 ||
        pixels > (int64_t(1) << 26) || spec.depth > 1)
        fail(path, ": image of ", spec.width, " x ", spec.height, " pixels and ",
             spec.nchannels,
             " channels is not allowed (allowed: 1 to 4 channels, at most 2^26 pixels, "
             "2D)");
    std::vector<float> px(size_t(pixels) * size_t(spec.nchannels));
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data()))
        fail(path, ": cannot read image: ", in->geterror());
    return px;
}

}  // namespace sss

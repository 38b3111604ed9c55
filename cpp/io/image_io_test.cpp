#include "io/image_io.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "core/check.h"
#include "testing/temp_file.h"

using namespace sss;
using sss::test::TempFile;

namespace {

// Writes a width x height RGB EXR with OpenImageIO (not our writer), in the given
// compression and pixel type, tiled when tile > 0.
void write_exr(const std::string& path, int width, int height,
               const std::string& compression, OIIO::TypeDesc type, int tile,
               std::vector<float>* pixels) {
    pixels->resize(size_t(width) * height * 3);
    // A smooth ramp (lossy compressions keep it close), exact in half
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            for (int c = 0; c < 3; ++c)
                (*pixels)[(size_t(y) * width + x) * 3 + c] = float(x + y + 8 * c) / 64.f;
    OIIO::ImageSpec spec(width, height, 3, type);
    spec.attribute("compression", compression);
    if (tile > 0) spec.tile_width = spec.tile_height = tile;
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, spec)) << OIIO::geterror();
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels->data()))
        << out->geterror();
    ASSERT_TRUE(out->close());
}

std::string read_error(const std::string& path) {
    int w, h, c;
    try {
        read_image(path, &w, &h, &c);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

}  // namespace

// The header check must accept what other writers produce: every compression, half and
// float, scan lines and tiles.
TEST(ImageIo, ReadsExrOfEveryCompressionAndLayout) {
    for (const char* compression :
         {"none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab"}) {
        for (int tile : {0, 16}) {
            SCOPED_TRACE(std::string(compression) + (tile ? " tiled" : " scanline"));
            TempFile file("a.exr", "");
            std::vector<float> expected;
            write_exr(file.path(), 37, 300, compression, OIIO::TypeDesc::HALF, tile,
                      &expected);
            int w = 0, h = 0, c = 0;
            const std::vector<float> px = read_image(file.path(), &w, &h, &c);
            ASSERT_EQ(w, 37);
            ASSERT_EQ(h, 300);
            ASSERT_EQ(c, 3);
            // Lossless ones give the values back; lossy ones (pxr24, b44, dwa) their mean
            const bool lossless =
                std::string("none rle zips zip piz").find(compression) !=
                std::string::npos;
            double sum = 0, expected_sum = 0;
            for (size_t i = 0; i < px.size(); ++i) {
                if (lossless) ASSERT_EQ(px[i], expected[i]) << i;
                sum += px[i];
                expected_sum += expected[i];
            }
            EXPECT_NEAR(sum, expected_sum, 0.02 * expected_sum);
        }
    }
}

// A file cut anywhere before its pixel data, or whose attribute sizes or data window are
// changed, is an sss::Error naming the file: never an allocation of what the header
// claims.
TEST(ImageIo, RefusesTruncatedAndLyingExrHeaders) {
    TempFile file("b.exr", "");
    std::vector<float> pixels;
    write_exr(file.path(), 64, 64, "zip", OIIO::TypeDesc::FLOAT, 0, &pixels);
    std::ifstream in(file.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    const size_t window = bytes.find("dataWindow");
    ASSERT_NE(window, std::string::npos);
    const size_t header_end = bytes.find(std::string("\0\0", 2), window);  // rough bound
    for (size_t cut = 0; cut < header_end + 8; ++cut) {
        TempFile cut_file("cut.exr", bytes.substr(0, cut));
        const std::string error = read_error(cut_file.path());
        ASSERT_NE(error.find("cut.exr"), std::string::npos) << "cut at " << cut;
    }
    // The data window claims 2^31 x 2^31 pixels
    std::string huge = bytes;
    const size_t box = window + std::string("dataWindow\0box2i\0", 17).size() + 4;
    for (int k = 0; k < 4; ++k) huge[box + 8 + k] = k == 3 ? '\x7f' : '\xff';
    for (int k = 0; k < 4; ++k) huge[box + 12 + k] = k == 3 ? '\x7f' : '\xff';
    TempFile huge_file("huge.exr", huge);
    EXPECT_NE(read_error(huge_file.path()).find("pixels is not allowed"),
              std::string::npos)
        << read_error(huge_file.path());
    // An attribute claims 1 GB
    std::string big = bytes;
    const size_t size_at = window + std::string("dataWindow\0box2i\0", 17).size();
    big.replace(size_at, 4, std::string("\0\0\0\x40", 4));
    TempFile big_file("big.exr", big);
    EXPECT_NE(read_error(big_file.path()).find("more than the file holds"),
              std::string::npos)
        << read_error(big_file.path());
    // A second dataWindow attribute: OpenEXR reads the first, a check of the last would
    // pass a huge first one (the fuzzer's file: tests/fuzz/regressions/image_exr/).
    const std::string attribute =
        bytes.substr(window, std::string("dataWindow\0box2i\0", 17).size() + 4 + 16);
    std::string twice = bytes;
    twice.insert(window + attribute.size(), attribute);
    TempFile twice_file("twice.exr", twice);
    EXPECT_NE(read_error(twice_file.path()).find("attribute 'dataWindow' appears twice"),
              std::string::npos)
        << read_error(twice_file.path());
}

TEST(ImageIo, RefusesContentThatIsNotTheExtensionsFormat) {
    TempFile png("c.exr", "\x89PNG\r\n\x1a\n not an exr");
    EXPECT_NE(read_error(png.path()).find("is not an OpenEXR file"), std::string::npos);
    TempFile exr("c.png", std::string("\x76\x2f\x31\x01\x02\0\0\0", 8));
    EXPECT_NE(read_error(exr.path()).find("is not a PNG file"), std::string::npos);
    TempFile tif("c.tif", "II*\0");
    EXPECT_NE(read_error(tif.path()).find("unsupported image format '.tif'"),
              std::string::npos);
}

// A PNG cut anywhere (in its header chunks), or whose chunk claims more bytes than the
// file holds, or whose IHDR claims more pixels than allowed, is an sss::Error naming the
// file.
TEST(ImageIo, RefusesTruncatedAndLyingPngChunks) {
    TempFile file("d.png", "");
    write_image(file.path(), std::vector<float>(20 * 10 * 3, 0.5f), 20, 10);
    std::ifstream in(file.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    // (libpng decodes a file cut after its pixel data, before IEND: no error is fine)
    for (size_t cut = 0; cut < bytes.size(); ++cut) {
        TempFile cut_file("cut.png", bytes.substr(0, cut));
        const std::string error = read_error(cut_file.path());
        ASSERT_TRUE(error.empty() ? cut > 8 + 25
                                  : error.find("cut.png") != std::string::npos)
            << "cut at " << cut << ": " << error;
    }
    // IHDR (at byte 8: length, "IHDR", width, height) claims 2^20 x 2^20 pixels
    std::string huge = bytes;
    huge.replace(16, 8, std::string("\0\x10\0\0\0\x10\0\0", 8));
    TempFile huge_file("huge.png", huge);
    EXPECT_NE(read_error(huge_file.path()).find("pixels is not allowed"),
              std::string::npos)
        << read_error(huge_file.path());
    // The chunk after IHDR claims 2^30 bytes
    std::string big = bytes;
    big.replace(8 + 12 + 13, 4, std::string("\x40\0\0\0", 4));
    TempFile big_file("big.png", big);
    EXPECT_NE(read_error(big_file.path()).find("more than the file holds"),
              std::string::npos)
        << read_error(big_file.path());
}

namespace {
std::string output_error(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}
}  // namespace

// Outputs are checked before a render: a directory, or a directory where no file can be
// made, is refused up front (not after the render, with its image lost).
TEST(ImageIo, OutputsThatCannotBeWrittenAreRefusedFirst) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / "sss_ImageIo_outputs.exr";
    fs::create_directories(dir);
    EXPECT_NE(
        output_error([&] { check_output_image(dir.string()); }).find("is a directory"),
        std::string::npos);
    fs::remove(dir);
    const std::string e = output_error([] { check_output_image("/proc/sss.exr"); });
    EXPECT_NE(e.find("/proc/sss.exr: cannot write in '/proc': "), std::string::npos) << e;
    TempFile fine("fine.exr", "");
    EXPECT_EQ(output_error([&] { check_output_image(fine.path()); }), "");
    EXPECT_EQ(fs::file_size(fine.path()), 0u);  // checked, not touched
}

// An image written through a symbolic link replaces the link's target; the scene's own
// files, named directly or through a link, are refused as outputs.
TEST(ImageIo, OutputsGoThroughLinksAndNeverOverAnInput) {
    namespace fs = std::filesystem;
    TempFile target("target.exr", "old");
    const fs::path link = fs::path(target.path()).parent_path() / "sss_ImageIo_link.exr";
    fs::remove(link);
    fs::create_symlink(fs::path(target.path()).filename(), link);
    write_image(link.string(), std::vector<float>(2 * 3 * 3, 0.5f), 2, 3);
    EXPECT_TRUE(fs::is_symlink(link));
    int w = 0, h = 0, c = 0;
    EXPECT_EQ(read_image(target.path(), &w, &h, &c).size(), 18u);
    EXPECT_EQ(output_target(link.string()), target.path());

    TempFile map("map.exr", "x");
    const std::vector<std::string> inputs{"/nonexistent.obj", map.path()};
    const std::string e =
        output_error([&] { check_output_is_not_an_input(map.path(), inputs); });
    EXPECT_NE(e.find("is a file the scene reads ('" + map.path() + "')"),
              std::string::npos)
        << e;
    EXPECT_EQ(output_error([&] { check_output_is_not_an_input(link.string(), inputs); }),
              "");
    EXPECT_NE(output_error([&] {
                  check_output_is_not_an_input(link.string(), {target.path()});
              }).find("is a file the scene reads"),
              std::string::npos);
    fs::remove(link);
}

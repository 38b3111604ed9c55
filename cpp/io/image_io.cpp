#include "io/image_io.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <utility>

#include "core/check.h"
#include "core/files.h"
#include "io/image_input.h"

namespace sss {

namespace {

std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    return ext;
}

}  // namespace

float linear_to_srgb(float v) {
    v = std::isnan(v) ? 0.f : std::clamp(v, 0.f, 1.f);  // +inf is white, not black
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

namespace {

// Creates a new file beside `target`, ending in `suffix`, with `mode` (less the umask),
// and returns its descriptor and name (fd < 0 with errno set if none can be made). Its
// name is short (not built from the target's, so that any name the directory takes has
// room) and of this process's own; a name taken already (a file left by a killed run of
// the same pid, as in a container) is passed over.
std::pair<int, std::string> create_beside(const std::filesystem::path& target,
                                          const std::string& suffix, mode_t mode) {
    static std::atomic<unsigned> count{0};
    for (int tries = 0;; ++tries) {
        const std::string name =
            (target.parent_path() / (".sss-" + std::to_string(::getpid()) + "-" +
                                     std::to_string(count++) + suffix))
                .string();
        const int fd =
            ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
        if (fd >= 0 || errno != EEXIST || tries == 1000) return {fd, name};
    }
}

}  // namespace

std::string output_target(const std::string& path) {
    namespace fs = std::filesystem;
    fs::path target(path);
    std::error_code ec;
    for (int links = 0; links < 40 && fs::is_symlink(target, ec); ++links) {
        const fs::path to = fs::read_symlink(target, ec);
        if (ec) break;
        target = to.is_absolute() ? to : target.parent_path() / to;
    }
    return target.string();
}

void check_output_image(const std::string& path) {
    namespace fs = std::filesystem;
    const fs::path target(output_target(path));
    std::error_code ec;
    if (fs::is_directory(target, ec))
        fail(path, ": is a directory (an output image needs a file name)");
    const std::string ext = lower_extension(path);
    if (ext != ".exr" && ext != ".png")
        fail(path, ": unsupported image format '", ext, "' (allowed: .exr, .png)");
    fs::path parent = target.parent_path();
    if (!parent.empty() && !fs::is_directory(parent))
        fail(path, ": output directory '", parent.string(), "' ",
             fs::exists(parent, ec) ? "is a file, not a directory" : "does not exist");
    // A name longer than the directory takes was found only when the written image was
    // moved into place, and the render was lost
    const std::string dir = parent.empty() ? "." : parent.string();
    const long name_max = ::pathconf(dir.c_str(), _PC_NAME_MAX);
    const size_t name_size = target.filename().string().size();
    if (name_max > 0 && name_size > size_t(name_max))
        fail(path, ": its file name is ", name_size, " bytes long (allowed: at most ",
             name_max, " in '", dir, "')");
    // The image replaces the file there: never a device, pipe or socket (through a link,
    // /dev/null would become a file), nor a file its owner has made read-only.
    struct stat st;
    if (::stat(target.c_str(), &st) != 0 && errno == ELOOP)
        fail(path, ": is a loop of symbolic links (an output image needs a file name)");
    if (::stat(target.c_str(), &st) == 0) {
        if (!S_ISREG(st.st_mode))
            fail(path,
                 ": is a device, pipe or socket, not a file (an output image is a "
                 "new file or replaces a regular one)");
        // access() alone passes everything for root (containers often run as root): a
        // file with no write permission for anyone is read-only too
        if ((::access(target.c_str(), W_OK) != 0 && errno == EACCES) ||
            (st.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH)) == 0)
            fail(path, ": is read-only (make it writable or choose another output)");
    }
    // Whether a file can be made there
    const auto [fd, probe] = create_beside(target, ".probe", 0600);
    if (fd < 0)
        fail(path, ": cannot write in '", parent.empty() ? "." : parent.string(),
             "': ", std::strerror(errno));
    ::close(fd);
    ::unlink(probe.c_str());
}

void check_output_is_not_an_input(const std::string& path,
                                  const std::vector<std::string>& inputs) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path target(output_target(path));
    if (!fs::exists(target, ec)) return;
    for (const std::string& input : inputs)
        if (fs::equivalent(target, input, ec))
            fail(path, ": is a file the scene reads ('", input,
                 "'): writing the image would overwrite it (choose another output)");
}

namespace {

// Writes `bytes` to a new file beside `target`, flushed to the disk, then renames it into
// place: an interrupted or failed write (a full disk) never leaves a truncated image
// where the previous one was, and every error is seen. A file replaced keeps its
// permission bits (where the file system allows).
void replace_file(const std::string& path, const std::filesystem::path& target,
                  const std::vector<unsigned char>& bytes) {
    struct stat old;
    const bool replaces = ::stat(target.c_str(), &old) == 0;
    // (not a structured binding: clang cannot capture one in the lambda below)
    const std::pair<int, std::string> made =
        create_beside(target, target.extension().string(), replaces ? 0600 : 0666);
    const int fd = made.first;
    const std::string& tmp = made.second;
    if (fd < 0) fail(path, ": cannot write image: ", std::strerror(errno));
    auto fail_with = [&](const char* what, int error) {
        ::close(fd);
        ::unlink(tmp.c_str());
        fail(path, ": ", what, ": ", std::strerror(error));
    };
    if (replaces)
        (void)::fchmod(fd, old.st_mode & 0777);  // where the file system lets us
    for (size_t done = 0; done < bytes.size();) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) fail_with("cannot write image", n < 0 ? errno : EIO);
        done += size_t(n);
    }
    if (::fsync(fd) != 0) fail_with("cannot write image", errno);
    if (::close(fd) != 0) {
        const int error = errno;
        ::unlink(tmp.c_str());
        fail(path, ": cannot write image: ", std::strerror(error));
    }
    if (::rename(tmp.c_str(), target.c_str()) != 0) {
        const int error = errno;
        ::unlink(tmp.c_str());
        fail(path, ": cannot move the written image into place: ", std::strerror(error));
    }
    // The rename itself on the disk (best effort: not every file system syncs
    // directories)
    const std::string dir =
        target.parent_path().empty() ? "." : target.parent_path().string();
    const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        (void)::fsync(dfd);
        ::close(dfd);
    }
}

// Encodes the image in memory (OpenImageIO's writer for the extension of `path`), then
// replace_file: the encoder's own file writes do not report every error (a PNG or a small
// EXR on a full disk came out empty, with success).
void write_atomically(const std::string& path, const OIIO::ImageSpec& spec,
                      OIIO::TypeDesc type, const void* data) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) fail(path, ": cannot create an image writer: ", OIIO::geterror());
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput memory(bytes);
    SSS_CHECK(out->supports("ioproxy"));
    out->set_ioproxy(&memory);
    if (!(out->open(path, spec) && out->write_image(type, data) && out->close()))
        fail(path, ": cannot encode image: ", out->geterror());
    replace_file(path, std::filesystem::path(output_target(path)), bytes);
}

}  // namespace

void write_image(const std::string& path, const std::vector<float>& pixels, int width,
                 int height, int channels) {
    check_output_image(path);
    SSS_CHECK(pixels.size() == size_t(width) * height * channels);
    if (lower_extension(path) == ".exr") {
        OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::FLOAT);
        spec.attribute("compression", "zip");
        write_atomically(path, spec, OIIO::TypeDesc::FLOAT, pixels.data());
        return;
    }
    std::vector<unsigned char> bytes(pixels.size());
    for (size_t i = 0; i < pixels.size(); ++i)
        bytes[i] = (unsigned char)std::lround(255.f * linear_to_srgb(pixels[i]));
    OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    write_atomically(path, spec, OIIO::TypeDesc::UINT8, bytes.data());
}

void write_exr_layers(const std::string& path, int width, int height,
                      const std::vector<ImageLayer>& layers) {
    check_output_image(path);
    if (lower_extension(path) != ".exr")
        fail(path, ": image layers need an .exr file (a .png holds one RGB image)");
    std::vector<std::string> names;
    for (const ImageLayer& layer : layers) {
        SSS_CHECK(layer.data.size() == size_t(width) * height * layer.channels.size());
        for (const std::string& c : layer.channels)
            names.push_back(layer.name.empty() ? c : layer.name + "." + c);
    }
    if (names.size() > size_t(kMaxLayeredChannels))
        fail(path, ": ", names.size(), " channels (allowed: at most ",
             kMaxLayeredChannels, ")");
    // A name given twice would leave one channel's data under both in the file.
    for (size_t i = 0; i < names.size(); ++i)
        for (size_t j = 0; j < i; ++j)
            if (names[i] == names[j])
                fail(path, ": channel '", names[i],
                     "' is given twice (layer and channel names must be unique)");
    const size_t pixels = size_t(width) * height, n = names.size();
    std::vector<float> interleaved(pixels * n);
    size_t first = 0;
    for (const ImageLayer& layer : layers) {
        const size_t k = layer.channels.size();
        for (size_t p = 0; p < pixels; ++p)
            for (size_t c = 0; c < k; ++c)
                interleaved[p * n + first + c] = layer.data[p * k + c];
        first += k;
    }
    OIIO::ImageSpec spec(width, height, int(n), OIIO::TypeDesc::FLOAT);
    spec.channelnames = names;
    spec.attribute("compression", "zip");
    write_atomically(path, spec, OIIO::TypeDesc::FLOAT, interleaved.data());
}

namespace {

// Limits on what read_image accepts: no image of ours needs more, and a header of a few
// bytes must not make a reader allocate gigabytes.
constexpr int64_t kMaxImagePixels = int64_t(1) << 26;
constexpr int kMaxImageChannels = 4;
constexpr int64_t kMaxChunkPixels = int64_t(1) << 22;

// Reads the header of an OpenEXR file (the layout of "OpenEXR File Layout",
// openexr.com) and refuses, before OpenEXR sees it, what would make OpenEXR allocate more
// than the file holds: an attribute whose size runs past the end of the file (OpenEXR
// allocates the declared size first), a data window beyond the pixel limit, or a chunk
// offset table longer than the file. An attribute named twice is refused too: OpenEXR
// keeps the first, this check would see the last (a fuzzed file hid a 16-million-pixel
// data window behind a second, small one). Multi-part and deep files are refused (not
// supported). Found by fuzzing (docs/fuzzing.md).
void check_exr_header(const std::string& path, int max_channels) {
    std::ifstream in(path, std::ios::binary);
    in.seekg(0, std::ios::end);
    const int64_t file_size = in.tellg();
    in.seekg(0);
    auto bad = [&](const auto&... what) {
        fail(path, ": not a readable OpenEXR file: ", what...);
    };
    auto read_u32 = [&] {
        unsigned char b[4];
        if (!in.read(reinterpret_cast<char*>(b), 4)) bad("the header ends early");
        return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 |
               uint32_t(b[3]) << 24;
    };
    auto read_string = [&](size_t max_length) {
        std::string str;
        char c;
        while (in.get(c) && c != '\0') {
            if (str.size() == max_length) bad("a name in the header is too long");
            str += c;
        }
        if (!in) bad("the header ends early");
        return str;
    };
    if (read_u32() != 20000630u) bad("wrong magic number");
    const uint32_t version = read_u32();
    if ((version & 0xff) != 2) bad("version ", version & 0xff, " (allowed: 2)");
    const bool tiled = version & 0x200, long_names = version & 0x400;
    if (version & 0x800) bad("deep data is not supported");
    if (version & 0x1000) bad("multi-part files are not supported");
    const size_t max_name = long_names ? 255 : 31;

    bool have_window = false;
    int channels = 0;
    int64_t width = 0, height = 0;
    int64_t lines_per_chunk = 0, tile_w = 0, tile_h = 0;
    std::set<std::string> names;
    for (;;) {
        const std::string name = read_string(max_name);
        if (name.empty()) break;
        if (!names.insert(name).second) bad("attribute '", name, "' appears twice");
        const std::string type = read_string(max_name);
        const int64_t size = int32_t(read_u32());
        const int64_t at = in.tellg();
        if (size < 0 || at + size > file_size)
            bad("attribute '", name, "' claims ", size,
                " bytes, more than the file holds");
        if (name == "dataWindow") {
            if (type != "box2i" || size != 16) bad("dataWindow is not a box2i");
            const int64_t x0 = int32_t(read_u32()), y0 = int32_t(read_u32());
            const int64_t x1 = int32_t(read_u32()), y1 = int32_t(read_u32());
            width = x1 - x0 + 1;
            height = y1 - y0 + 1;
            have_window = true;
        } else if (name == "compression" && size == 1) {
            // Scan lines per chunk of each compression (NONE, RLE, ZIPS, ZIP, PIZ, PXR24,
            // B44, B44A, DWAA, DWAB)
            constexpr std::array<int, 10> lines{1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
            const int c = in.get();
            if (c < 0 || c >= int(lines.size())) bad("unknown compression ", c);
            lines_per_chunk = lines[c];
        } else if (name == "channels") {
            // chlist: per channel a name, then pixel type, pLinear and 3 reserved bytes,
            // x and y sampling (4 + 4 + 4 + 4 bytes); an empty name ends the list
            if (type != "chlist") bad("channels is not a chlist");
            channels = 0;
            for (;;) {
                const std::string channel = read_string(max_name);
                if (channel.empty()) break;
                if (++channels > max_channels)
                    fail(path, ": more than ", max_channels,
                         " channels is not allowed (allowed: 1 to ", max_channels, ")",
                         max_channels < kMaxLayeredChannels
                             ? "; a multilayer EXR's layers are read by "
                               "sssphere.read_layers"
                             : "");
                const uint32_t pixel_type = read_u32();
                read_u32();
                const uint32_t x_sampling = read_u32(), y_sampling = read_u32();
                if (pixel_type > 2)
                    bad("channel '", channel, "' has unknown pixel type ", pixel_type);
                if (x_sampling != 1 || y_sampling != 1)
                    bad("channel '", channel, "' is subsampled (not supported)");
            }
            if (int64_t(in.tellg()) > at + size)
                bad("the channel list overruns its size");
        } else if (name == "tiles" && size == 9) {
            tile_w = read_u32();
            tile_h = read_u32();
        }
        in.seekg(at + size);
    }
    if (!have_window) bad("no dataWindow");
    if (channels == 0) bad("no channels");
    if (lines_per_chunk == 0) bad("no compression");
    if (width < 1 || height < 1 || width > kMaxImagePixels || height > kMaxImagePixels ||
        width * height > kMaxImagePixels)
        fail(path, ": image of ", width, " x ", height,
             " pixels is not allowed (allowed: at most 2^26 pixels)");
    // OpenEXR decodes a chunk (a block of scan lines, or a tile of the first level) at a
    // time and allocates several buffers of a whole chunk each (twelve of up to 1 GB for
    // a file the fuzzer made): chunks are limited to 2^22 pixels (a 16384-pixel-wide
    // image in blocks of 256 lines). Each chunk has an 8-byte offset in the table that
    // follows the header.
    int64_t chunks = 0, chunk_w = width, chunk_h = lines_per_chunk;
    if (tiled) {
        if (tile_w < 1 || tile_h < 1 || tile_w > kMaxImagePixels ||
            tile_h > kMaxImagePixels)
            bad("tiled, but no valid tile size");
        chunk_w = tile_w;
        chunk_h = tile_h;
        chunks = ((width + tile_w - 1) / tile_w) * ((height + tile_h - 1) / tile_h);
    } else {
        chunks = (height + lines_per_chunk - 1) / lines_per_chunk;
    }
    if (chunk_w * chunk_h > kMaxChunkPixels)
        fail(path, ": image of ", width, " x ", height, " pixels in chunks of ", chunk_w,
             " x ", chunk_h,
             " is not allowed (allowed: chunks of at most 2^22 pixels; scan-line blocks "
             "are as wide as the image)");
    if (int64_t(in.tellg()) + 8 * chunks > file_size)
        bad("the file is shorter than its table of ", chunks, " chunk offsets");
}

// Walks the chunks of a PNG file (after its signature) and refuses, before libpng sees
// them, a chunk longer than what is left of the file (libpng allocates a chunk's declared
// length before reading it: found by fuzzing, 2 GB for a file of 200 bytes) and an IHDR
// beyond the pixel limit.
void check_png_chunks(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    in.seekg(0, std::ios::end);
    const int64_t file_size = in.tellg();
    auto bad = [&](const auto&... what) {
        fail(path, ": not a readable PNG file: ", what...);
    };
    auto read_u32 = [&] {  // big-endian
        unsigned char b[4];
        if (!in.read(reinterpret_cast<char*>(b), 4)) bad("a chunk header ends early");
        return uint32_t(b[0]) << 24 | uint32_t(b[1]) << 16 | uint32_t(b[2]) << 8 |
               uint32_t(b[3]);
    };
    int64_t at = 8;  // after the signature
    for (bool first = true; at < file_size; first = false) {
        in.seekg(at);
        const int64_t length = read_u32();
        char type[5] = {};
        if (!in.read(type, 4)) bad("a chunk header ends early");
        if (length > 0x7fffffff || at + 12 + length > file_size)
            bad("chunk '", type, "' claims ", length, " bytes, more than the file holds");
        if (first != (std::string(type) == "IHDR") || (first && length != 13))
            bad("the first chunk is not a 13-byte IHDR");
        if (first) {
            const int64_t width = read_u32(), height = read_u32();
            if (width < 1 || height < 1 || width > kMaxImagePixels ||
                height > kMaxImagePixels || width * height > kMaxImagePixels)
                fail(path, ": image of ", width, " x ", height,
                     " pixels is not allowed (allowed: at most 2^26 pixels)");
        }
        if (std::string(type) == "IEND") break;
        at += 12 + length;
    }
}

// The format's signature at the start of the file: OIIO would otherwise try every reader
// it has on a file whose content does not match its extension.
bool starts_with(const std::string& path, const std::string& magic) {
    std::ifstream in(path, std::ios::binary);
    std::string head(magic.size(), '\0');
    return in.read(head.data(), std::streamsize(head.size())) && head == magic;
}

}  // namespace

namespace {

// read_image and read_exr_layers: files of 1 to max_channels channels.
std::vector<float> read_checked(const std::string& path, int max_channels, int* width,
                                int* height, int* channels,
                                std::vector<std::string>* channel_names) {
    check_input_file(path, "image file");
    const std::string ext = lower_extension(path);
    if (ext == ".exr") {
        if (!starts_with(path, std::string("\x76\x2f\x31\x01", 4)))
            fail(path, ": is not an OpenEXR file (wrong signature)");
        check_exr_header(path, max_channels);
    } else if (ext == ".png") {
        if (!starts_with(path, "\x89PNG\r\n\x1a\n"))
            fail(path, ": is not a PNG file (wrong signature)");
        check_png_chunks(path);
    } else {
        fail(path, ": unsupported image format '", ext, "' (allowed: .exr, .png)");
    }
    // Only the reader of that format (no fall-back to the others)
    auto in = OIIO::ImageInput::create(ext.substr(1));
    OIIO::ImageSpec spec;
    if (!in || !in->open(path, spec))
        fail(path, ": cannot read image: ", in ? in->geterror() : OIIO::geterror());
    *width = spec.width;
    *height = spec.height;
    *channels = spec.nchannels;
    // A header may claim any size: refuse what no image of ours needs before allocating
    // (found by fuzzing: an EXR of a few bytes asked for gigabytes).
    const int64_t pixels = int64_t(spec.width) * int64_t(spec.height);
    if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1 ||
        spec.nchannels > max_channels || pixels > kMaxImagePixels || spec.depth > 1)
        fail(path, ": image of ", spec.width, " x ", spec.height, " pixels and ",
             spec.nchannels, " channels is not allowed (allowed: 1 to ", max_channels,
             " channels, at most 2^26 pixels, 2D)",
             max_channels < kMaxLayeredChannels && spec.nchannels > max_channels
                 ? "; a multilayer EXR's layers are read by sssphere.read_layers"
                 : "");
    std::vector<float> px(size_t(pixels) * size_t(spec.nchannels));
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data()))
        fail(path, ": cannot read image: ", in->geterror());
    if (channel_names) *channel_names = spec.channelnames;
    return px;
}

}  // namespace

std::vector<float> read_image(const std::string& path, int* width, int* height,
                              int* channels) {
    return read_checked(path, kMaxImageChannels, width, height, channels, nullptr);
}

std::vector<float> read_exr_layers(const std::string& path, int* width, int* height,
                                   std::vector<std::string>* channel_names) {
    if (lower_extension(path) != ".exr")
        fail(path, ": image layers are read from .exr files only");
    int channels;
    return read_checked(path, kMaxLayeredChannels, width, height, &channels,
                        channel_names);
}

void install_image_reader() {
    image_reader() = [](const std::string& path) {
        ImageData img;
        img.pixels = read_image(path, &img.width, &img.height, &img.channels);
        return img;
    };
}

}  // namespace sss

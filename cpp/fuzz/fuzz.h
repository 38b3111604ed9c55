// The fuzz targets (docs/fuzzing.md). Each takes one input, feeds it to one parser and
// returns 0. Documented input errors (sss::Error) are the expected outcome for most
// inputs and are swallowed; anything else is a finding: a crash or sanitizer report, a
// hang, an allocation past libFuzzer's limit, an exception of another type escaping, or
// an sss::Error from a failed SSS_CHECK ("internal check failed": an internal invariant
// that the parser let bad input reach), which guarded() rethrows as std::logic_error.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "core/check.h"

namespace sss::fuzz {

// Every target, by name; the libFuzzer executables are fuzz_<name>.
int fuzz_scene(const uint8_t* data, size_t size);      // parse_scene (JSON text)
int fuzz_mesh_obj(const uint8_t* data, size_t size);   // load_mesh on a .obj file
int fuzz_mesh_ply(const uint8_t* data, size_t size);   // .ply, ASCII and binary
int fuzz_mesh_off(const uint8_t* data, size_t size);   // .off
int fuzz_mesh_stl(const uint8_t* data, size_t size);   // .stl, ASCII and binary
int fuzz_model(const uint8_t* data, size_t size);      // parse_decoder (model file)
int fuzz_image_exr(const uint8_t* data, size_t size);  // read_image on a .exr file
int fuzz_image_png(const uint8_t* data, size_t size);  // read_image on a .png file

struct Target {
    const char* name;
    int (*run)(const uint8_t*, size_t);
};
inline constexpr Target kTargets[] = {
    {"scene", fuzz_scene},         {"mesh_obj", fuzz_mesh_obj},
    {"mesh_ply", fuzz_mesh_ply},   {"mesh_off", fuzz_mesh_off},
    {"mesh_stl", fuzz_mesh_stl},   {"model", fuzz_model},
    {"image_exr", fuzz_image_exr}, {"image_png", fuzz_image_png},
};

// A directory of this process's own (under $TMPDIR), made on first use and removed at
// exit: the readers that take a path read the input from a file written here.
const std::filesystem::path& scratch_dir();

// Writes `size` bytes to scratch_dir()/name and returns the path.
std::string write_scratch_file(const std::string& name, const uint8_t* data, size_t size);

// Runs body(); swallows sss::Error except a failed SSS_CHECK (see above). Returns 0.
template <typename Body>
int guarded(Body&& body) {
    try {
        body();
    } catch (const Error& e) {
        // SSS_CHECK's message starts so (core/check.h); an input error starts with the
        // file's name, and may quote the input anywhere after it.
        const char kCheck[] = "internal check failed: ";
        if (std::strncmp(e.what(), kCheck, sizeof kCheck - 1) == 0)
            throw std::logic_error(e.what());
    }
    return 0;
}

}  // namespace sss::fuzz

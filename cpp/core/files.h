// Input files: only regular files are opened. A FIFO, a device or a socket named where a
// scene, mesh, model or image is expected would block a read forever, or never end.
#pragma once

#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/check.h"

namespace sss {

// Throws sss::Error "<path>: <what> does not exist" (or is a directory, or is not a
// regular file) unless `path` is a regular file (after symbolic links).
inline void check_input_file(const std::string& path, const char* what) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    const char* a =
        std::string("aeiou").find(what[0]) != std::string::npos ? "an " : "a ";
    if (ec.value() == ELOOP) fail(path, ": is a loop of symbolic links, not ", a, what);
    if (ec || !fs::exists(st)) fail(path, ": ", what, " does not exist");
    if (fs::is_directory(st)) fail(path, ": is a directory, not ", a, what);
    if (!fs::is_regular_file(st))
        fail(path, ": is not a regular file (a FIFO, device or socket?); ", a, what,
             " must be a regular file");
}

// The whole of input file `path` (check_input_file first). Throws sss::Error naming the
// file if it cannot be read, or if it is too large for memory (not std::bad_alloc, which
// names nothing).
inline std::string read_input_file(const std::string& path, const char* what) {
    check_input_file(path, what);
    std::ifstream in(path, std::ios::binary);
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(path, ec);
    if (!in || ec) fail(path, ": ", what, " cannot be read");
    std::string data;
    try {
        data.resize(size_t(size));
    } catch (const std::exception&) {  // bad_alloc, length_error
        fail(path, ": ", what, " of ", size, " bytes does not fit in memory");
    }
    if (!in.read(data.data(), std::streamsize(size)) && !in.eof())
        fail(path, ": ", what, " cannot be read");
    data.resize(size_t(in.gcount()));  // a file that shrank meanwhile
    return data;
}

}  // namespace sss

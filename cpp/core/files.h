// Input files: only regular files are opened. A FIFO, a device or a socket named where a
// scene, mesh, model or image is expected would block a read forever, or never end.
#pragma once

#include <filesystem>
#include <string>

#include "core/check.h"

namespace sss {

// Throws sss::Error "<path>: <what> does not exist" (or is a directory, or is not a
// regular file) unless `path` is a regular file (after symbolic links).
inline void check_input_file(const std::string& path, const char* what) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st)) fail(path, ": ", what, " does not exist");
    if (fs::is_directory(st)) fail(path, ": is a directory, not a ", what);
    if (!fs::is_regular_file(st))
        fail(path, ": is not a regular file (a FIFO, device or socket?); a ", what,
             " must be a regular file");
}

}  // namespace sss

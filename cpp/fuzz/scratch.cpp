// The scratch directory of the fuzz targets (fuzz/fuzz.h).
#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "fuzz/fuzz.h"

namespace sss::fuzz {

namespace {

std::filesystem::path* g_scratch = nullptr;

void remove_scratch() {
    std::error_code ec;
    std::filesystem::remove_all(*g_scratch, ec);
}

}  // namespace

const std::filesystem::path& scratch_dir() {
    if (g_scratch == nullptr) {
        // One per process: libFuzzer's -jobs/-fork run several processes side by side
        g_scratch =
            new std::filesystem::path(std::filesystem::temp_directory_path() /
                                      ("sssphere-fuzz-" + std::to_string(getpid())));
        std::filesystem::create_directories(*g_scratch);
        std::atexit(remove_scratch);
    }
    return *g_scratch;
}

std::string write_scratch_file(const std::string& name, const uint8_t* data,
                               size_t size) {
    const std::string path = (scratch_dir() / name).string();
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    out.close();
    if (!out) {
        std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
        std::abort();
    }
    return path;
}

}  // namespace sss::fuzz

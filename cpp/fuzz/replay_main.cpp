// sssphere_fuzz_replay <target> <file or directory>...: runs one fuzz target
// (fuzz/fuzz.h) over the given files and every file in the given directories (missing
// directories are skipped; hidden files and README.md are not inputs). ctest runs it over
// tests/fuzz/corpus/<target> and tests/fuzz/regressions/<target>, so every input that
// once found a bug is checked by every test run, without clang or libFuzzer. Exit status
// 1 if any input ends in a finding that the process survives (an exception other than
// sss::Error); a crash ends the process with the file named just before.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iterator>
#include <vector>

#include "fuzz/fuzz.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s <target> <file or directory>...\n", argv[0]);
        return 2;
    }
    const sss::fuzz::Target* target = nullptr;
    for (const auto& t : sss::fuzz::kTargets)
        if (t.name == std::string(argv[1])) target = &t;
    if (target == nullptr) {
        std::fprintf(stderr, "%s: unknown target '%s'\n", argv[0], argv[1]);
        return 2;
    }
    std::vector<fs::path> files;
    for (int i = 2; i < argc; ++i) {
        if (fs::is_directory(argv[i])) {
            for (const auto& e : fs::directory_iterator(argv[i])) {
                const std::string name = e.path().filename().string();
                if (e.is_regular_file() && name[0] != '.' && name != "README.md")
                    files.push_back(e.path());
            }
        } else if (fs::exists(argv[i])) {
            files.emplace_back(argv[i]);
        }
    }
    std::sort(files.begin(), files.end());
    int failures = 0;
    for (const fs::path& file : files) {
        std::fprintf(stderr, "%s: %s\n", target->name, file.c_str());
        std::ifstream in(file, std::ios::binary);
        const std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
        try {
            target->run(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
        } catch (const std::exception& e) {
            std::fprintf(stderr, "FINDING: %s: %s\n", file.c_str(), e.what());
            ++failures;
        }
    }
    std::printf("%s: %zu inputs, %d findings\n", target->name, files.size(), failures);
    return failures == 0 ? 0 : 1;
}

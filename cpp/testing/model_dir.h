// A temporary directory of model files (lengthgen.json, pathgen.json, eventgen.json),
// removed when the object goes out of scope. Named after the running test (plus a suffix,
// so that one test can have several).
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "nn/decoder.h"
#include "nn/random_models.h"

namespace sss::test {

class ModelDir {
public:
    explicit ModelDir(const std::string& suffix = "") {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = std::filesystem::temp_directory_path() /
                (std::string("sss_modeldir_") + info->test_suite_name() + "_" +
                 info->name() + suffix);
        std::filesystem::create_directories(path_);
    }
    ~ModelDir() { std::filesystem::remove_all(path_); }
    ModelDir(const ModelDir&) = delete;
    ModelDir& operator=(const ModelDir&) = delete;

    void write(const std::string& file, const std::string& text) {
        std::ofstream(path_ / file) << text;
    }
    void write(const Decoder& d) {
        std::string file = d.name;
        for (char& c : file) c = char(std::tolower(c));
        write(file + ".json", decoder_to_json(d));
    }
    // The three random Table-1 decoders, each with `edit` applied first (e.g. to change a
    // training range).
    template <class Edit>
    void write_random(uint64_t seed, Edit edit) {
        for (const char* name : {"LengthGen", "PathGen", "EventGen"}) {
            Decoder d = random_decoder(name, seed);
            edit(d);
            write(d);
        }
    }
    void write_random(uint64_t seed = 1) {
        write_random(seed, [](Decoder&) {});
    }
    // The two random cut sphere decoders (cutlengthgen.json, cutpathgen.json).
    void write_random_cut(uint64_t seed = 1) {
        write(random_cut_decoder("CutLengthGen", seed));
        write(random_cut_decoder("CutPathGen", seed + 1));
    }
    std::string path() const { return path_.string(); }

private:
    std::filesystem::path path_;
};

// Sets training range `param` of decoder d to [lo, hi].
inline void set_training_range(Decoder& d, const std::string& param, double lo,
                               double hi) {
    for (auto& [name, range] : d.training_ranges)
        if (name == param) range = {lo, hi};
}

}  // namespace sss::test

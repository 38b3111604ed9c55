// A file in the temporary directory, removed when the object goes out of scope.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace sss::test {

class TempFile {
public:
    TempFile(const std::string& name, const std::string& content) {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = (std::filesystem::temp_directory_path() /
                 (std::string("sss_") + info->test_suite_name() + "_" + info->name() +
                  "_" + name))
                    .string();
        std::ofstream(path_) << content;
    }
    ~TempFile() { std::filesystem::remove(path_); }
    const std::string& path() const { return path_; }

private:
    std::string path_;
};

}  // namespace sss::test

// Checking error messages in the C++ tests.
#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "core/check.h"

namespace sss::test {

// The message of the sss::Error f() throws, or "" if it throws none.
inline std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

}  // namespace sss::test

// The message contains `part`.
#define EXPECT_HAS(msg, part) \
    EXPECT_NE((msg).find(part), std::string::npos) << "message: " << (msg)

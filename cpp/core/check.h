// Errors and always-on checks. Bad user input throws sss::Error with a message that names
// the file, the field, the value and what is allowed; SSS_CHECK guards internal
// invariants and is never compiled out (pbrt's CHECK). The Python binding maps Error to
// ValueError.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace sss {

struct Error : std::runtime_error {
    using std::runtime_error::runtime_error;
};

template <typename... Args>
[[noreturn]] void fail(const Args&... args) {
    std::ostringstream os;
    (os << ... << args);
    throw Error(os.str());
}

}  // namespace sss

#define SSS_CHECK(cond)                                                                  \
    do {                                                                                 \
        if (!(cond))                                                                     \
            ::sss::fail("internal check failed: ", #cond, " (", __FILE__, ":", __LINE__, \
                        ")");                                                            \
    } while (0)

// Every integrator, in one list: SSS_INTEGRATORS(X) calls X(name, help) for each, `name`
// being the value of the `integrator` option and the prefix of the factory its file
// (render/integrators/<name>.cpp) defines, `help` what the option's help says of it.
// Adding an integrator is one file and one entry here (docs/extending.md). Kept free of
// the renderer's headers: the options table (render/options.cpp) reads the names from it.
#pragma once

#include <string>
#include <vector>

// clang-format off
#define SSS_INTEGRATORS(X)                                                   \
    X(pt, "path tracing")                                                    \
    X(st, "sphere tracing")
// clang-format on

namespace sss {

struct IntegratorName {
    const char* name;
    const char* help;
};

inline const std::vector<IntegratorName>& integrator_names() {
#define SSS_INTEGRATOR_NAME(name, help) {#name, help},
    static const std::vector<IntegratorName> names = {
        SSS_INTEGRATORS(SSS_INTEGRATOR_NAME)};
#undef SSS_INTEGRATOR_NAME
    return names;
}

}  // namespace sss

// Meshes built in code for the C++ tests of geometry/.
#pragma once

#include <cmath>

#include "geometry/mesh.h"

namespace sss::test {

// A closed mesh with concavities and thin parts: a flattened, twisted icosphere.
inline TriangleMesh lumpy_mesh() {
    TriangleMesh m = make_icosphere({0, 0, 0}, 1.f, 3);
    for (Vec3& p : m.positions) {
        float bump = 1.f + 0.35f * std::sin(5.f * p.x) * std::cos(4.f * p.y);
        p = Vec3(p.x * bump, 0.3f * p.y * bump, p.z * bump);
    }
    return m;
}

}  // namespace sss::test

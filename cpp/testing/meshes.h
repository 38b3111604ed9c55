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

// The cube [-1, 1]^3, faces wound outward.
inline TriangleMesh cube_mesh() {
    std::vector<Vec3d> v;
    for (int i = 0; i < 8; ++i)
        v.emplace_back(i & 1 ? 1.0 : -1.0, i & 2 ? 1.0 : -1.0, i & 4 ? 1.0 : -1.0);
    return make_closed_mesh(v,
                            {{0, 2, 3, 1},
                             {4, 5, 7, 6},
                             {0, 1, 5, 4},
                             {2, 6, 7, 3},
                             {0, 4, 6, 2},
                             {1, 3, 7, 5}},
                            "cube");
}

// An open square of two triangles at height y, x and z in [-half, half].
inline TriangleMesh floor_mesh(double y, double half = 2.0) {
    return make_open_mesh(
        {{-half, y, -half}, {half, y, -half}, {half, y, half}, {-half, y, half}},
        {{0, 2, 1}, {0, 3, 2}}, "floor");
}

}  // namespace sss::test

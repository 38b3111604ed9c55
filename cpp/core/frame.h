// Orthonormal frames: local coordinates (x, y, z) with z along a given unit vector.
#pragma once

#include <cmath>

#include "core/vec.h"

namespace sss {

struct Frame {
    Vec3 s, t, n;  // right-handed: s x t = n

    // Any orthonormal completion of unit vector n (Duff et al. 2017, branchless).
    static Frame from_z(Vec3 n) {
        float sign = std::copysign(1.f, n.z);
        float a = -1.f / (sign + n.z);
        float b = n.x * n.y * a;
        Frame f;
        f.s = {1.f + sign * n.x * n.x * a, sign * b, -sign * n.x};
        f.t = {b, sign + n.y * n.y * a, -n.y};
        f.n = n;
        return f;
    }
    Vec3 to_world(Vec3 v) const { return s * v.x + t * v.y + n * v.z; }
    Vec3 to_local(Vec3 v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
};

}  // namespace sss

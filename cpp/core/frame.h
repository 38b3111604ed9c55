// Orthonormal frames: local coordinates (x, y, z) with z along a given unit vector.
// Portable: the shaders compile it too (core/portable.h).
#ifndef SSS_CORE_FRAME_H
#define SSS_CORE_FRAME_H

#ifdef __cplusplus
#include "core/portable.h"
#include "core/vec.h"
namespace sss {
#endif

struct Frame {
    Vec3 s, t, n;  // right-handed: s x t = n
#ifdef __cplusplus
    static Frame from_z(Vec3 n);
    Vec3 to_world(Vec3 v) const;
    Vec3 to_local(Vec3 v) const;
#endif
};

// Any orthonormal completion of unit vector n (Duff et al. 2017, branchless).
SSS_FN Frame frame_from_z(Vec3 n) {
    float sign = copysign(1.f, n.z);
    float a = -1.f / (sign + n.z);
    float b = n.x * n.y * a;
    Frame f;
    f.s = Vec3(1.f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f.t = Vec3(b, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}

SSS_FN Vec3 frame_to_world(Frame f, Vec3 v) { return f.s * v.x + f.t * v.y + f.n * v.z; }

SSS_FN Vec3 frame_to_local(Frame f, Vec3 v) {
    return Vec3(dot(v, f.s), dot(v, f.t), dot(v, f.n));
}

#ifdef __cplusplus
inline Frame Frame::from_z(Vec3 n) { return frame_from_z(n); }
inline Vec3 Frame::to_world(Vec3 v) const { return frame_to_world(*this, v); }
inline Vec3 Frame::to_local(Vec3 v) const { return frame_to_local(*this, v); }
}  // namespace sss
#endif

#endif  // SSS_CORE_FRAME_H

// Small value types for geometry and colour: Vec3 (float, used for points, directions and
// RGB spectra alike). No third-party includes: this layer knows nothing of scenes.
// Functions that are not inlined take Vec3 by const reference: by value, GCC packs it
// into xmm0 through two stores and an 8-byte reload, a failed store forward per call (4 %
// of the thin torus's render time, and more for "st" than for "pt").
#pragma once

#include <algorithm>
#include <cmath>

#include "core/portable.h"

namespace sss {

struct Vec3 {
    float x = 0, y = 0, z = 0;

    constexpr Vec3() = default;
    constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
    constexpr explicit Vec3(float v) : x(v), y(v), z(v) {}

    constexpr float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }

    constexpr Vec3 operator+(Vec3 o) const { return {x + o.x, y + o.y, z + o.z}; }
    constexpr Vec3 operator-(Vec3 o) const { return {x - o.x, y - o.y, z - o.z}; }
    constexpr Vec3 operator*(Vec3 o) const { return {x * o.x, y * o.y, z * o.z}; }
    constexpr Vec3 operator/(Vec3 o) const { return {x / o.x, y / o.y, z / o.z}; }
    constexpr Vec3 operator*(float s) const { return {x * s, y * s, z * s}; }
    constexpr Vec3 operator/(float s) const { return {x / s, y / s, z / s}; }
    constexpr Vec3 operator-() const { return {-x, -y, -z}; }
    Vec3& operator+=(Vec3 o) {
        x += o.x;
        y += o.y;
        z += o.z;
        return *this;
    }
    Vec3& operator-=(Vec3 o) {
        x -= o.x;
        y -= o.y;
        z -= o.z;
        return *this;
    }
    Vec3& operator*=(Vec3 o) {
        x *= o.x;
        y *= o.y;
        z *= o.z;
        return *this;
    }
    Vec3& operator*=(float s) {
        x *= s;
        y *= s;
        z *= s;
        return *this;
    }
    Vec3& operator/=(float s) {
        x /= s;
        y /= s;
        z /= s;
        return *this;
    }
    constexpr bool operator==(Vec3 o) const { return x == o.x && y == o.y && z == o.z; }
    constexpr bool operator!=(Vec3 o) const { return !(*this == o); }
};

constexpr Vec3 operator*(float s, Vec3 v) { return v * s; }
constexpr float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(Vec3 a, Vec3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(Vec3 v) { return std::sqrt(dot(v, v)); }
inline Vec3 normalize(Vec3 v) { return v / length(v); }
// normalize() for a triangle's cross product: at large or small scales its squared length
// leaves float's normal range (edges of 4e9 square past FLT_MAX, of 1e-10 to 0), where
// normalize() gives 0 or NaN. Such a vector is scaled by its largest component first;
// in range the result is normalize()'s, bit for bit.
inline Vec3 unit_normal(Vec3 v) {
    const float l2 = dot(v, v);
    if (l2 >= kFloatMinNormal && l2 <= kFloatMax) return v / std::sqrt(l2);
    const float m = std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z)));
    return normalize(v / m);
}
inline Vec3 min(Vec3 a, Vec3 b) {
    return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
inline Vec3 max(Vec3 a, Vec3 b) {
    return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
inline Vec3 exp(Vec3 v) { return {std::exp(v.x), std::exp(v.y), std::exp(v.z)}; }
inline Vec3 abs(Vec3 v) { return {std::abs(v.x), std::abs(v.y), std::abs(v.z)}; }
inline float max_component(Vec3 v) { return std::max(v.x, std::max(v.y, v.z)); }
inline float min_component(Vec3 v) { return std::min(v.x, std::min(v.y, v.z)); }
inline float average(Vec3 v) { return (v.x + v.y + v.z) / 3.f; }
inline bool is_finite(Vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
inline bool is_black(Vec3 v) { return v.x == 0.f && v.y == 0.f && v.z == 0.f; }

// A point in double precision: scene files' coordinates before they are moved into the
// render frame (render/scene.h), so that a scene far from the origin loses nothing.
struct Vec3d {
    double x = 0, y = 0, z = 0;

    constexpr Vec3d() = default;
    constexpr Vec3d(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
    constexpr explicit Vec3d(Vec3 v) : x(v.x), y(v.y), z(v.z) {}
    constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
    constexpr Vec3d operator+(Vec3d o) const { return {x + o.x, y + o.y, z + o.z}; }
    constexpr Vec3d operator-(Vec3d o) const { return {x - o.x, y - o.y, z - o.z}; }
    constexpr Vec3d operator*(double s) const { return {x * s, y * s, z * s}; }
    // Rounded to the nearest float per component.
    constexpr Vec3 to_float() const { return {float(x), float(y), float(z)}; }
};

inline double length(Vec3d v) { return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z); }

// Axis-aligned bounding box.
struct Bounds3 {
    Vec3 lo{INFINITY}, hi{-INFINITY};
    void extend(Vec3 p) {
        lo = min(lo, p);
        hi = max(hi, p);
    }
    Vec3 extent() const { return hi - lo; }
    Vec3 center() const { return (lo + hi) * 0.5f; }
    bool contains(Vec3 p) const {
        return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z &&
               p.z <= hi.z;
    }
    bool overlaps(const Bounds3& b) const {  // touching counts
        return lo.x <= b.hi.x && b.lo.x <= hi.x && lo.y <= b.hi.y && b.lo.y <= hi.y &&
               lo.z <= b.hi.z && b.lo.z <= hi.z;
    }
};

}  // namespace sss

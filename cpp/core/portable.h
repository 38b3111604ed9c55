// The common subset of C++ and GLSL in which core/frame.h and the headers of cpp/shared/
// are written, so that the CPU and the shaders compile the same maths
// (docs/architecture.md, "Math written once"). This is the C++ side;
// cpp/gpu/shaders/portable.glsl is the GLSL side.
//
// A portable header:
// - guards C++-only parts (includes, the namespace, member functions) with
//   `#ifdef __cplusplus`, and uses include guards (glslang has no `#pragma once`);
// - declares functions `SSS_FN` and constants `SSS_CONST`, output parameters
//   `SSS_OUT(float) x` and in-out ones `SSS_INOUT(T) x`; writes float literals with a
//   suffix (`1.f`) and 64-bit ones with `ul` (GLSL's uint64_t, from
//   GL_EXT_shader_explicit_arithmetic_types_int64);
// - builds vectors as `Vec3(x, y, z)` (GLSL's vec3) and calls the maths unqualified
//   (`sqrt`, `clamp`, `log1p`, `copysign`, ...); GLSL lacks `log1p`, `expm1`, `atan2`,
//   `copysign` and nextafter (here `next_float_up` / `next_float_down`), which
//   portable.glsl provides, and C++ lacks GLSL's `floatBitsToInt` / `intBitsToFloat`,
//   which this file provides;
// - computes in `real` where the CPU wants double precision (double here, float in GLSL).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#define SSS_FN inline
#define SSS_CONST inline constexpr
#define SSS_OUT(T) T&
#define SSS_INOUT(T) T&

namespace sss {

using real = double;

inline constexpr float kInf = std::numeric_limits<float>::infinity();
// float's largest finite value and smallest normal one (FLT_MAX, FLT_MIN): where a square
// or product leaves float's range, the portable maths change formula.
inline constexpr float kFloatMax = 3.40282347e38f;
inline constexpr float kFloatMinNormal = 1.17549435e-38f;

using std::abs;
using std::acos;
using std::atan2;
using std::clamp;
using std::copysign;
using std::cos;
using std::exp;
using std::expm1;
using std::floor;
using std::log;
using std::log1p;
using std::max;
using std::min;
using std::sin;
using std::sqrt;

// GLSL's bit casts between float and int.
inline int floatBitsToInt(float f) {
    int i;
    std::memcpy(&i, &f, sizeof(i));
    return i;
}
inline float intBitsToFloat(int i) {
    float f;
    std::memcpy(&f, &i, sizeof(f));
    return f;
}

// The next float towards +infinity and towards -infinity (GLSL has no nextafter).
inline float next_float_up(float v) { return std::nextafter(v, INFINITY); }
inline float next_float_down(float v) { return std::nextafter(v, -INFINITY); }

}  // namespace sss

// The GLSL side of core/portable.h: what the portable headers (core/frame.h, cpp/shared/)
// expect, so that the shaders compile the CPU's maths from the same source.

#define Vec3 vec3
#define SSS_FN
#define SSS_CONST const
#define SSS_OUT(T) out T
#define SSS_INOUT(T) inout T
#define uint32_t uint
#define real float

const float kInf = 1.0 / 0.0;
const float kFloatMax = 3.40282347e38;  // FLT_MAX, as core/portable.h
const float kFloatMinNormal = 1.17549435e-38;  // FLT_MIN

// log(1 + x) and exp(x) - 1, accurate for small |x| too (GLSL has neither): the albedos
// near 1 of dense media make log(phi) a difference of nearly equal numbers, which a
// GPU's log (absolute error ~2^-21) would get wrong by 1 %. For x = phi - 1, x is exact.
float log1p(float x) {
    return abs(x) < 1e-2 ? x * (1.0 - x * (0.5 - x * (1.0 / 3.0 - 0.25 * x))) : log(1.0 + x);
}
float expm1(float x) {
    return abs(x) < 1e-2 ? x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0))) : exp(x) - 1.0;
}

// C's atan2 (GLSL spells it atan(y, x)).
float atan2(float y, float x) { return atan(y, x); }

// |a| with the sign of b (of -0.0 too), as C's copysign.
float copysign(float a, float b) { return (floatBitsToUint(b) >> 31) != 0u ? -abs(a) : abs(a); }

// The next float towards +infinity and towards -infinity (C's nextafter), by the bits:
// floats of one sign are ordered as their bit patterns.
float next_float_up(float v) {
    if (isinf(v) && v > 0.0) return v;
    if (v == 0.0) return uintBitsToFloat(1u);  // +0 and -0: the smallest positive float
    uint bits = floatBitsToUint(v);
    return uintBitsToFloat(v > 0.0 ? bits + 1u : bits - 1u);
}
float next_float_down(float v) {
    if (isinf(v) && v < 0.0) return v;
    if (v == 0.0) return uintBitsToFloat(0x80000001u);  // the largest negative float
    uint bits = floatBitsToUint(v);
    return uintBitsToFloat(v > 0.0 ? bits - 1u : bits + 1u);
}

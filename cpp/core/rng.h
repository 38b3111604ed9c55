// Random numbers: PCG32 (O'Neill 2014) with streams derived from a counter by a strong
// 64-bit mixer, so the stream of (seed, pixel, sample) does not depend on which thread
// renders it or in which order (images are identical for any thread count). Portable
// (core/portable.h): the shaders draw the same streams from this source.
#ifndef SSS_CORE_RNG_H
#define SSS_CORE_RNG_H

#ifdef __cplusplus
#include <cstdint>

#include "core/portable.h"
namespace sss {
#endif

// SplitMix64 finaliser: a bijective avalanche mix of 64 bits.
SSS_FN uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ul;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ul;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebul;
    return z ^ (z >> 31);
}

struct RngState {
    uint64_t state, inc;
};

SSS_FN uint32_t rng_next_u32(SSS_INOUT(RngState) r) {
    uint64_t old = r.state;
    r.state = old * 6364136223846793005ul + r.inc;
    uint32_t xorshifted = uint32_t(((old >> 18) ^ old) >> 27);
    uint32_t rot = uint32_t(old >> 59);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

// The stream identified by up to three counters (e.g. seed, pixel index, sample index).
SSS_FN RngState rng_make(uint64_t a, uint64_t b, uint64_t c) {
    uint64_t key = mix64(mix64(mix64(a) ^ b) ^ c);
    RngState r;
    r.inc = (mix64(key ^ 0x5851f42d4c957f2dul) << 1) | 1ul;
    r.state = 0ul;
    rng_next_u32(r);
    r.state += key;
    rng_next_u32(r);
    return r;
}

// Uniform float in [0, 1): 24 random mantissa bits, never 1.
SSS_FN float rng_uniform(SSS_INOUT(RngState) r) {
    return float(rng_next_u32(r) >> 8) * (1.f / 16777216.f);
}

#ifdef __cplusplus
class Rng {
public:
    explicit Rng(uint64_t a = 0, uint64_t b = 0, uint64_t c = 0)
        : s_(rng_make(a, b, c)) {}
    uint32_t next_u32() { return rng_next_u32(s_); }
    float uniform() { return rng_uniform(s_); }
    // For the portable functions that draw from the stream (shared/path.h).
    RngState& state() { return s_; }

private:
    RngState s_;
};
}  // namespace sss
#endif

#endif  // SSS_CORE_RNG_H

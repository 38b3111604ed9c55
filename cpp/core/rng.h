// Random numbers: PCG32 (O'Neill 2014) with streams derived from a counter by a strong
// 64-bit mixer, so the stream of (seed, pixel, sample) does not depend on which thread
// renders it or in which order (images are identical for any thread count).
#pragma once

#include <cstdint>

namespace sss {

// SplitMix64 finaliser: a bijective avalanche mix of 64 bits.
constexpr uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

class Rng {
public:
    // A stream identified by up to three counters (e.g. seed, pixel index, sample index).
    explicit Rng(uint64_t a = 0, uint64_t b = 0, uint64_t c = 0) {
        uint64_t key = mix64(mix64(mix64(a) ^ b) ^ c);
        inc_ = (mix64(key ^ 0x5851f42d4c957f2dull) << 1u) | 1u;
        state_ = 0;
        next_u32();
        state_ += key;
        next_u32();
    }

    uint32_t next_u32() {
        uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }

    // Uniform float in [0, 1): 24 random mantissa bits, never 1.
    float uniform() { return float(next_u32() >> 8) * 0x1p-24f; }

private:
    uint64_t state_ = 0, inc_ = 0;
};

}  // namespace sss

// PCG32 streams keyed by (seed, pixel, sample): the same generator and keying as
// cpp/core/rng.h, so a path on the GPU starts from the same random numbers as on the CPU.
// Needs GL_EXT_shader_explicit_arithmetic_types_int64.

uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ul;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ul;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebul;
    return z ^ (z >> 31);
}

struct Rng {
    uint64_t state, inc;
};

uint rng_next_u32(inout Rng r) {
    uint64_t old = r.state;
    r.state = old * 6364136223846793005ul + r.inc;
    uint xorshifted = uint(((old >> 18) ^ old) >> 27);
    uint rot = uint(old >> 59);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

Rng rng_make(uint64_t a, uint64_t b, uint64_t c) {
    uint64_t key = mix64(mix64(mix64(a) ^ b) ^ c);
    Rng r;
    r.inc = (mix64(key ^ 0x5851f42d4c957f2dul) << 1) | 1ul;
    r.state = 0ul;
    rng_next_u32(r);
    r.state += key;
    rng_next_u32(r);
    return r;
}

// Uniform in [0, 1): 24 random mantissa bits, never 1.
float rng_uniform(inout Rng r) { return float(rng_next_u32(r) >> 8) * (1.0 / 16777216.0); }

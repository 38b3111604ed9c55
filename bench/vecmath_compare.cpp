// Which vector-math library for the SIMD decoder? Times and checks the two kernels that
// dominate a sphere step (about 100 scalar exp/log/sin/cos calls per step, measured before the SIMD decoders): Softplus (torch's form,
// x > 20 ? x : log1p(exp(x))) and Box-Muller Gaussians (log, sqrt, sin, cos), on 4-lane
// vectors, for Highway (hwy/contrib/math), xsimd and SLEEF, against scalar libm.
//
// Not part of the CMake build (it needs all three libraries). Build it twice, once per ISA:
//   g++ -O2 -std=c++17 -march=x86-64-v2 bench/vecmath_compare.cpp -o /tmp/vm_v2 -lsleef
//   g++ -O2 -std=c++17 -march=x86-64-v3 bench/vecmath_compare.cpp -o /tmp/vm_v3 -lsleef
// and run each: it prints one JSON object (ns per 4-lane vector, max relative error).
// The decision and the numbers are in bench/README.md.
#include <hwy/highway.h>
#include <hwy/contrib/math/math-inl.h>
#include <sleef.h>
#include <xsimd/xsimd.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace hn = hwy::HWY_NAMESPACE;

namespace {

constexpr float kTwoPi = 6.28318530717958647692f;

// ---- Softplus on 4 floats -------------------------------------------------------------------
struct Libm {
    static const char* name() { return "libm"; }
    static void softplus(const float* x, float* y) {
        for (int i = 0; i < 4; ++i) y[i] = x[i] > 20.f ? x[i] : std::log1p(std::exp(x[i]));
    }
    static void box_muller(const float* u1, const float* u2, float* z) {
        for (int i = 0; i < 4; ++i) {
            float r = std::sqrt(-2.f * std::log(1.f - u1[i]));
            z[i] = r * std::cos(kTwoPi * u2[i]);
            z[i + 4] = r * std::sin(kTwoPi * u2[i]);
        }
    }
};

struct Hwy {
    static const char* name() { return "highway"; }
    static void softplus(const float* x, float* y) {
        const hn::FixedTag<float, 4> d;
        auto v = hn::LoadU(d, x);
        auto sp = hn::Log1p(d, hn::Exp(d, v));
        hn::StoreU(hn::IfThenElse(hn::Gt(v, hn::Set(d, 20.f)), v, sp), d, y);
    }
    static void box_muller(const float* u1, const float* u2, float* z) {
        const hn::FixedTag<float, 4> d;
        auto one = hn::Set(d, 1.f);
        auto r = hn::Sqrt(hn::Mul(hn::Set(d, -2.f), hn::Log(d, hn::Sub(one, hn::LoadU(d, u1)))));
        auto a = hn::Mul(hn::Set(d, kTwoPi), hn::LoadU(d, u2));
        hn::StoreU(hn::Mul(r, hn::Cos(d, a)), d, z);
        hn::StoreU(hn::Mul(r, hn::Sin(d, a)), d, z + 4);
    }
};

// xsimd 8.1 has no 4-lane FMA architecture usable next to AVX2; sse4_2 batches (GCC fuses
// their mul + add when FMA is enabled).
using XArch = xsimd::sse4_2;
struct XSimd {
    static const char* name() { return "xsimd"; }
    using B = xsimd::batch<float, XArch>;
    static void softplus(const float* x, float* y) {
        B v = B::load_unaligned(x);
        B sp = xsimd::log1p(xsimd::exp(v));
        xsimd::select(v > B(20.f), v, sp).store_unaligned(y);
    }
    static void box_muller(const float* u1, const float* u2, float* z) {
        B r = xsimd::sqrt(B(-2.f) * xsimd::log(B(1.f) - B::load_unaligned(u1)));
        auto sc = xsimd::sincos(B(kTwoPi) * B::load_unaligned(u2));
        (r * sc.second).store_unaligned(z);
        (r * sc.first).store_unaligned(z + 4);
    }
};

// SLEEF: the explicit ISA entry points (sse4 at -march=x86-64-v2, avx2128 at v3), 1-ulp.
struct Sleef {
    static const char* name() { return "sleef_u10"; }
    static void softplus(const float* x, float* y) {
        __m128 v = _mm_loadu_ps(x);
#if defined(__AVX2__)
        __m128 sp = Sleef_log1pf4_u10avx2128(Sleef_expf4_u10avx2128(v));
#else
        __m128 sp = Sleef_log1pf4_u10sse4(Sleef_expf4_u10sse4(v));
#endif
        _mm_storeu_ps(y, _mm_blendv_ps(sp, v, _mm_cmpgt_ps(v, _mm_set1_ps(20.f))));
    }
    static void box_muller(const float* u1, const float* u2, float* z) {
        __m128 one = _mm_set1_ps(1.f);
#if defined(__AVX2__)
        __m128 l = Sleef_logf4_u10avx2128(_mm_sub_ps(one, _mm_loadu_ps(u1)));
        Sleef___m128_2 sc = Sleef_sincosf4_u10avx2128(_mm_mul_ps(_mm_set1_ps(kTwoPi), _mm_loadu_ps(u2)));
#else
        __m128 l = Sleef_logf4_u10sse4(_mm_sub_ps(one, _mm_loadu_ps(u1)));
        Sleef___m128_2 sc = Sleef_sincosf4_u10sse4(_mm_mul_ps(_mm_set1_ps(kTwoPi), _mm_loadu_ps(u2)));
#endif
        __m128 r = _mm_sqrt_ps(_mm_mul_ps(_mm_set1_ps(-2.f), l));
        _mm_storeu_ps(z, _mm_mul_ps(r, sc.y));
        _mm_storeu_ps(z + 4, _mm_mul_ps(r, sc.x));
    }
};
struct SleefU35 : Sleef {
    static const char* name() { return "sleef_u35"; }
    static void box_muller(const float* u1, const float* u2, float* z) {
        __m128 one = _mm_set1_ps(1.f);
#if defined(__AVX2__)
        __m128 l = Sleef_logf4_u35avx2128(_mm_sub_ps(one, _mm_loadu_ps(u1)));
        Sleef___m128_2 sc = Sleef_sincosf4_u35avx2128(_mm_mul_ps(_mm_set1_ps(kTwoPi), _mm_loadu_ps(u2)));
#else
        __m128 l = Sleef_logf4_u35sse4(_mm_sub_ps(one, _mm_loadu_ps(u1)));
        Sleef___m128_2 sc = Sleef_sincosf4_u35sse4(_mm_mul_ps(_mm_set1_ps(kTwoPi), _mm_loadu_ps(u2)));
#endif
        __m128 r = _mm_sqrt_ps(_mm_mul_ps(_mm_set1_ps(-2.f), l));
        _mm_storeu_ps(z, _mm_mul_ps(r, sc.y));
        _mm_storeu_ps(z + 4, _mm_mul_ps(r, sc.x));
    }
};

double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

volatile float g_sink;

// Softplus of a 16-float layer (4 vectors), chained so that each layer waits for the last
// (as in a decoder), and Box-Muller on 4 lanes (8 normals) from a fresh uniform block.
template <class L>
void run(bool first) {
    // Accuracy: softplus against a double reference on [-60, 40]; Box-Muller against double.
    double sp_err = 0, bm_err = 0;
    for (int i = 0; i <= 400000; ++i) {
        float x[4], y[4];
        for (int k = 0; k < 4; ++k) x[k] = -60.f + 100.f * float(4 * i + k) / 1600004.f;
        L::softplus(x, y);
        for (int k = 0; k < 4; ++k) {
            double ref = x[k] > 20.f ? double(x[k]) : std::log1p(std::exp(double(x[k])));
            if (ref > 1e-30) sp_err = std::max(sp_err, std::abs(y[k] - ref) / ref);
        }
    }
    std::mt19937 gen(1);
    std::uniform_real_distribution<float> U(0.f, 1.f);
    for (int i = 0; i < 200000; ++i) {
        float u1[4], u2[4], z[8];
        for (int k = 0; k < 4; ++k) { u1[k] = U(gen); u2[k] = U(gen); }
        L::box_muller(u1, u2, z);
        for (int k = 0; k < 4; ++k) {
            double r = std::sqrt(-2.0 * std::log(1.0 - double(u1[k])));
            double c = r * std::cos(2.0 * M_PI * double(u2[k])), s = r * std::sin(2.0 * M_PI * double(u2[k]));
            bm_err = std::max(bm_err, std::max(std::abs(z[k] - c), std::abs(z[k + 4] - s)));
        }
    }

    // Timing.
    alignas(16) float h[16];
    for (int k = 0; k < 16; ++k) h[k] = -3.f + 0.4f * float(k);
    const int reps = 400000;
    double best_sp = 1e30, best_bm = 1e30;
    for (int trial = 0; trial < 25; ++trial) {
        double t0 = now();
        for (int r = 0; r < reps; ++r) {
            for (int k = 0; k < 16; k += 4) L::softplus(h + k, h + k);
            for (int k = 0; k < 16; ++k) h[k] = h[k] * 0.5f - 1.f;  // keep values bounded
        }
        double t1 = now();
        best_sp = std::min(best_sp, (t1 - t0) / reps / 4 * 1e9);
        // Independent blocks of uniforms (throughput, as for the 12 draws of one step).
        static float us[2048];
        for (int k = 0; k < 2048; ++k) us[k] = U(gen);
        alignas(16) float z[8];
        float acc = 0;
        t0 = now();
        for (int r = 0; r < reps; ++r) {
            const float* u = us + (r & 255) * 8;
            L::box_muller(u, u + 4, z);
            acc += z[0] + z[7];
        }
        t1 = now();
        g_sink = acc;
        best_bm = std::min(best_bm, (t1 - t0) / reps * 1e9);
    }
    g_sink = h[3];
    std::printf("%s  \"%s\": {\"softplus_ns_per_vec4\": %.2f, \"box_muller_ns_per_vec4\": %.2f, "
                "\"softplus_max_rel_err\": %.3g, \"box_muller_max_abs_err\": %.3g}",
                first ? "" : ",\n", L::name(), best_sp, best_bm, sp_err, bm_err);
}

}  // namespace

int main() {
#if defined(__AVX2__)
    std::printf("{\"isa\": \"x86-64-v3 (AVX2+FMA)\",\n");
#else
    std::printf("{\"isa\": \"x86-64-v2 (SSE4.2)\",\n");
#endif
    run<Libm>(true);
    run<Hwy>(false);
    run<XSimd>(false);
    run<Sleef>(false);
    run<SleefU35>(false);
    std::printf("}\n");
}

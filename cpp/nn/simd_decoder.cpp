// SIMD decoder kernels, compiled once per Highway target (foreach_target re-includes this
// file) and picked at run time; the packing and the public entry points are compiled once
// (HWY_ONCE).
// Highway's foreach_target pattern needs exactly this include order.
// clang-format off
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "nn/simd_decoder.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/highway.h>
#include <hwy/contrib/math/math-inl.h>
// clang-format on

#include "nn/simd_decoder.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <new>
#include <vector>
#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

#include "core/check.h"
#include "core/rng.h"
#include "shared/softplus.h"

#ifndef SSS_NN_SIMD_DECODER_CONSTANTS
#define SSS_NN_SIMD_DECODER_CONSTANTS
namespace sss::simd_detail {
constexpr float kTwoPi = 6.28318530717958647692f;
// Activation buffers of up to kMaxPaths paths of this many floats live on the stack.
constexpr int kStackFloats = 64;
constexpr int kMaxPaths = 16;
// Highway's Exp is valid up to ~88.7 (std::exp returns inf beyond): arguments are clamped
// here, which keeps exp(88) = 1.6e38 finite where the scalar code would overflow.
constexpr float kMaxExpArg = 88.f;
// Slack after every padded array: the widest vector (16 floats) may run past a multiple
// of 4.
constexpr int kSlack = 16;
}  // namespace sss::simd_detail
#endif

HWY_BEFORE_NAMESPACE();
namespace sss {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;
using namespace simd_detail;

// y[0 .. K*N) = bias + sum_j x[j] * wt[j * stride + (0 .. K*N)]: K output vectors of tag
// D. Even and odd j go to separate accumulators when K is small, to shorten the
// dependency chain.
template <int K, class D>
HWY_INLINE void MatVecBlock(D d, const float* HWY_RESTRICT wt, size_t stride,
                            const float* HWY_RESTRICT bias, const float* HWY_RESTRICT x,
                            int in, float* HWY_RESTRICT y) {
    const size_t N = hn::Lanes(d);
    hn::Vec<D> a0[K], a1[K];
    for (int k = 0; k < K; ++k) {
        a0[k] = hn::LoadU(d, bias + k * N);
        a1[k] = hn::Zero(d);
    }
    int j = 0;
    for (; j + 1 < in; j += 2) {
        const auto x0 = hn::Set(d, x[j]), x1 = hn::Set(d, x[j + 1]);
        const float* w0 = wt + size_t(j) * stride;
        const float* w1 = w0 + stride;
        for (int k = 0; k < K; ++k) {
            a0[k] = hn::MulAdd(hn::LoadU(d, w0 + k * N), x0, a0[k]);
            a1[k] = hn::MulAdd(hn::LoadU(d, w1 + k * N), x1, a1[k]);
        }
    }
    if (j < in) {
        const auto x0 = hn::Set(d, x[j]);
        const float* w0 = wt + size_t(j) * stride;
        for (int k = 0; k < K; ++k)
            a0[k] = hn::MulAdd(hn::LoadU(d, w0 + k * N), x0, a0[k]);
    }
    for (int k = 0; k < K; ++k) hn::StoreU(hn::Add(a0[k], a1[k]), d, y + k * N);
}

template <class D>
HWY_INLINE void MatVec(D d, const float* HWY_RESTRICT wt, const float* HWY_RESTRICT bias,
                       const float* HWY_RESTRICT x, int in, int out_pad,
                       float* HWY_RESTRICT y) {
    const int N = int(hn::Lanes(d));
    int o = 0;
    for (; o + 4 * N <= out_pad; o += 4 * N)
        MatVecBlock<4>(d, wt + o, out_pad, bias + o, x, in, y + o);
    switch ((out_pad - o) / N) {
        case 3:
            MatVecBlock<3>(d, wt + o, out_pad, bias + o, x, in, y + o);
            break;
        case 2:
            MatVecBlock<2>(d, wt + o, out_pad, bias + o, x, in, y + o);
            break;
        case 1:
            MatVecBlock<1>(d, wt + o, out_pad, bias + o, x, in, y + o);
            break;
        default:
            break;
    }
}

// PyTorch's Softplus, log1p(exp(x)) (x itself above its threshold 20, where the two agree
// to float precision), as max(x, 0) + log1p(y) with y = exp(-|x|) in (0, 1]: there
// log1p(y) = 2 atanh(s), s = y / (2 + y) <= 1/3, whose odd series to s^13 is within 1e-8
// of it. One Exp and a short polynomial: about half the cost of Highway's Exp + Log1p,
// which is what the decoders spend most of their time on.
template <class D>
HWY_INLINE hn::Vec<D> Softplus(D d, hn::Vec<D> x) {
    const auto y = hn::Exp(d, hn::Neg(hn::Abs(x)));
    const auto s = hn::Div(y, hn::Add(hn::Set(d, 2.f), y));
    const auto s2 = hn::Mul(s, s);
    auto p = hn::Set(d, 2.f / 13.f);
    p = hn::MulAdd(p, s2, hn::Set(d, 2.f / 11.f));
    p = hn::MulAdd(p, s2, hn::Set(d, 2.f / 9.f));
    p = hn::MulAdd(p, s2, hn::Set(d, 2.f / 7.f));
    p = hn::MulAdd(p, s2, hn::Set(d, 2.f / 5.f));
    p = hn::MulAdd(p, s2, hn::Set(d, 2.f / 3.f));
    p = hn::MulAdd(p, s2, hn::Set(d, 2.f));
    return hn::MulAdd(p, s, hn::Max(x, hn::Zero(d)));
}

// Softplus on y[0 .. n), n a multiple of Lanes(d).
template <class D>
HWY_INLINE void SoftplusInPlace(D d, float* HWY_RESTRICT y, int n) {
    const int N = int(hn::Lanes(d));
    for (int i = 0; i < n; i += N) hn::StoreU(Softplus(d, hn::LoadU(d, y + i)), d, y + i);
}

// Calls f with the widest tag (16, 8 or 4 floats, capped by the target) whose lane count
// divides n (a multiple of 4).
template <class F>
HWY_INLINE void WithBlockTag(int n, F&& f) {
    if (n % 16 == 0)
        f(hn::CappedTag<float, 16>());
    else if (n % 8 == 0)
        f(hn::CappedTag<float, 8>());
    else
        f(hn::CappedTag<float, 4>());
}

// Runs the network for K inputs (path k at x + k * input_width). Each layer writes path
// k's padded outputs at out + k * out_pad, so one layer of all K paths is one contiguous
// array: Softplus runs over it with the widest vectors, and the K independent dependency
// chains overlap in the out-of-order core. Returns the last layer's outputs, path k's
// [means | log-variances] at k * 2 * output_half().
HWY_INLINE const float* RunNet(const SimdDecoder& net, int K, const float* HWY_RESTRICT x,
                               float* HWY_RESTRICT buf0, float* HWY_RESTRICT buf1) {
    const float* data = net.data();
    const float* in = x;
    int in_stride = net.input_width();
    float* out = buf0;
    for (const SimdDecoder::Layer& L : net.layers()) {
        const float* wt = data + L.weight;
        const float* bias = data + L.bias;
        WithBlockTag(L.out_pad, [&](auto d) {
            for (int k = 0; k < K; ++k)
                MatVec(d, wt, bias, in + k * in_stride, L.in, L.out_pad,
                       out + k * L.out_pad);
        });
        if (L.softplus)
            WithBlockTag(K * L.out_pad,
                         [&](auto d) { SoftplusInPlace(d, out, K * L.out_pad); });
        in = out;
        in_stride = L.out_pad;
        out = out == buf0 ? buf1 : buf0;
    }
    return in;
}

// Calls f(buf0, buf1) with two activation buffers for K paths.
template <class F>
HWY_INLINE void WithScratch(const SimdDecoder& net, int K, F&& f) {
    if (K <= kMaxPaths && net.scratch_floats() <= kStackFloats) {
        HWY_ALIGN float buf[2][kMaxPaths * kStackFloats + kSlack];
        f(buf[0], buf[1]);
    } else {
        size_t n = size_t(K) * net.scratch_floats() + kSlack;
        std::vector<float> heap(2 * n);
        f(heap.data(), heap.data() + n);
    }
}

void EvaluateNet(const SimdDecoder* net, int K, const float* x, float* mean,
                 float* logvar) {
    WithScratch(*net, K, [&](float* b0, float* b1) {
        const float* y = RunNet(*net, K, x, b0, b1);
        const int half = net->output_half(), n = net->num_outputs();
        for (int k = 0; k < K; ++k) {
            const float* yk = y + 2 * k * half;
            std::copy(yk, yk + n, mean + k * n);
            std::copy(yk + half, yk + half + n, logvar + k * n);
        }
    });
}

void SampleNet(const SimdDecoder* net, int K, const float* x, const float* eps,
               float* u) {
    WithScratch(*net, K, [&](float* b0, float* b1) {
        const float* y = RunNet(*net, K, x, b0, b1);
        const int half = net->output_half(), n = net->num_outputs();
        if (half > kStackFloats) {  // very wide outputs: not vectorized
            for (int k = 0; k < K; ++k)
                for (int i = 0; i < n; ++i)
                    u[k * n + i] =
                        y[2 * k * half + i] +
                        std::exp(0.5f * y[2 * k * half + half + i]) * eps[k * n + i];
            return;
        }
        HWY_ALIGN float e[kStackFloats + kSlack], r[kStackFloats + kSlack];
        std::fill(e + n, e + half, 0.f);
        WithBlockTag(half, [&](auto d) {
            const int N = int(hn::Lanes(d));
            const auto h = hn::Set(d, 0.5f), big = hn::Set(d, kMaxExpArg);
            for (int k = 0; k < K; ++k) {
                const float* yk = y + 2 * k * half;
                std::copy(eps + k * n, eps + (k + 1) * n, e);
                for (int i = 0; i < half; i += N) {
                    // exp(logvar / 2), the argument clamped where Highway's Exp stops
                    // being valid
                    const auto sd =
                        hn::Exp(d, hn::Min(hn::Mul(h, hn::LoadU(d, yk + half + i)), big));
                    hn::StoreU(hn::MulAdd(sd, hn::LoadU(d, e + i), hn::LoadU(d, yk + i)),
                               d, r + i);
                }
                std::copy(r, r + n, u + k * n);
            }
        });
    });
}

// The network with paths in lanes (SimdDecoder::sample_lanes): rows of kLanes floats, one
// per variable. Lanes [0, count) rounded up to whole vectors are computed.
void SampleLanes(const SimdDecoder* net, const float* HWY_RESTRICT x,
                 const float* HWY_RESTRICT eps, float* HWY_RESTRICT u, int count) {
    constexpr int kL = SimdDecoder::kLanes;
    const hn::CappedTag<float, kL> d;
    const int N = int(hn::Lanes(d));
    const int lanes = (count + N - 1) / N * N;
    const float* data = net->data();
    const int half = net->output_half(), n_out = net->num_outputs();
    const auto h = hn::Set(d, 0.5f), big = hn::Set(d, kMaxExpArg);
    auto run = [&](float* HWY_RESTRICT b0, float* HWY_RESTRICT b1) {
        const float* in = x;
        float* out = b0;
        const auto& layers = net->layers();
        for (size_t l = 0; l < layers.size(); ++l) {
            const SimdDecoder::Layer& L = layers[l];
            const float* wt = data + L.weight;
            const float* bias = data + L.bias;
            // Four output rows at a time: their chains are independent, and written
            // side by side they overlap in the core even for a single vector of lanes.
            for (int o0 = 0; o0 < L.out_pad; o0 += 4) {
                for (int b = 0; b < lanes; b += N) {
                    hn::Vec<decltype(d)> acc[4];
                    for (int k = 0; k < 4; ++k) acc[k] = hn::Set(d, bias[o0 + k]);
                    for (int j = 0; j < L.in; ++j) {
                        const auto xj = hn::Load(d, in + j * kL + b);
                        const float* w = wt + size_t(j) * L.out_pad + o0;
                        for (int k = 0; k < 4; ++k)
                            acc[k] = hn::MulAdd(hn::Set(d, w[k]), xj, acc[k]);
                    }
                    if (L.softplus)
                        for (int k = 0; k < 4; ++k) acc[k] = Softplus(d, acc[k]);
                    for (int k = 0; k < 4; ++k)
                        hn::Store(acc[k], d, out + (o0 + k) * kL + b);
                }
            }
            in = out;
            out = out == b0 ? b1 : b0;
        }
        // u = mean + exp(logvar / 2) eps, the argument clamped where Exp stops being
        // valid
        for (int o = 0; o < n_out; ++o)
            for (int b = 0; b < lanes; b += N) {
                const auto sd = hn::Exp(
                    d, hn::Min(hn::Mul(h, hn::Load(d, in + (half + o) * kL + b)), big));
                hn::Store(hn::MulAdd(sd, hn::Load(d, eps + o * kL + b),
                                     hn::Load(d, in + o * kL + b)),
                          d, u + o * kL + b);
            }
    };
    if (net->scratch_floats() <= kStackFloats) {
        HWY_ALIGN float buf[2][kStackFloats * kL];
        run(buf[0], buf[1]);
    } else {
        // Aligned heap rows for very wide layers.
        const size_t n = size_t(net->scratch_floats()) * kL;
        std::unique_ptr<float[], SimdDecoder::FreeAligned> heap(static_cast<float*>(
            ::operator new[](2 * n * sizeof(float), std::align_val_t(64))));
        run(heap.get(), heap.get() + n);
    }
}

// An encoding or its inverse on rows of kLanes floats (code_lanes).
void CodeLanes(const Encoding* e, bool decode, const float* HWY_RESTRICT in,
               float* HWY_RESTRICT out, int count) {
    const hn::CappedTag<float, SimdDecoder::kLanes> d;
    const int N = int(hn::Lanes(d));
    const auto a = hn::Set(d, e->a), b = hn::Set(d, e->b), one = hn::Set(d, 1.f);
    for (int i = 0; i < count; i += N) {
        const auto v = hn::Load(d, in + i);
        auto r = v;
        switch (e->kind) {
            case Encoding::Kind::Affine:
                r = decode ? hn::Div(hn::Sub(v, b), a) : hn::MulAdd(a, v, b);
                break;
            case Encoding::Kind::Log: {
                const auto s = hn::Set(d, e->s), c = hn::Set(d, e->c);
                if (decode) {
                    const auto t =
                        hn::Min(hn::Div(hn::Sub(v, b), a), hn::Set(d, kMaxExpArg));
                    r = hn::Div(hn::Sub(hn::Exp(d, t), c), s);
                } else {
                    r = hn::MulAdd(a, hn::Log(d, hn::MulAdd(s, v, c)), b);
                }
                break;
            }
            case Encoding::Kind::Logit: {
                const auto lo = hn::Set(d, e->lo), hi = hn::Set(d, e->hi),
                           ep = hn::Set(d, e->eps);
                if (decode) {
                    // lo - eps + (hi - lo + 2 eps) / (1 + exp(-(e - b) / a))
                    const auto t = hn::Min(hn::Neg(hn::Div(hn::Sub(v, b), a)),
                                           hn::Set(d, kMaxExpArg));
                    const auto width = hn::Add(hn::Sub(hi, lo), hn::Add(ep, ep));
                    r = hn::Add(hn::Sub(lo, ep),
                                hn::Div(width, hn::Add(one, hn::Exp(d, t))));
                } else {
                    const auto ratio =
                        hn::Div(hn::Add(hn::Sub(v, lo), ep), hn::Add(hn::Sub(hi, v), ep));
                    r = hn::MulAdd(a, hn::Log(d, ratio), b);
                }
                break;
            }
        }
        hn::Store(r, d, out + i);
    }
}

// c = r cos a, s = r sin a with r = sqrt(-2 ln(1 - xr)), a = 2 pi xa, on n (a multiple of
// 4) lanes.
void BoxMuller(const float* xr, const float* xa, float* c, float* s, int n) {
    WithBlockTag(n, [&](auto d) {
        const int N = int(hn::Lanes(d));
        const auto one = hn::Set(d, 1.f), m2 = hn::Set(d, -2.f),
                   two_pi = hn::Set(d, kTwoPi);
        for (int i = 0; i < n; i += N) {
            const auto r =
                hn::Sqrt(hn::Mul(m2, hn::Log(d, hn::Sub(one, hn::LoadU(d, xr + i)))));
            const auto a = hn::Mul(two_pi, hn::LoadU(d, xa + i));
            hn::StoreU(hn::Mul(r, hn::Cos(d, a)), d, c + i);
            hn::StoreU(hn::Mul(r, hn::Sin(d, a)), d, s + i);
        }
    });
}

void SoftplusArray(float* y, int n) {
    WithBlockTag(n, [&](auto d) { SoftplusInPlace(d, y, n); });
}

const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace sss
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace sss {

HWY_EXPORT(EvaluateNet);
HWY_EXPORT(SampleNet);
HWY_EXPORT(SampleLanes);
HWY_EXPORT(CodeLanes);
HWY_EXPORT(BoxMuller);
HWY_EXPORT(TargetName);
HWY_EXPORT(SoftplusArray);

using namespace simd_detail;

namespace {
void use_default_target_once();  // below, with the targets
}  // namespace

void SimdDecoder::FreeAligned::operator()(float* p) const {
    ::operator delete[](p, std::align_val_t(64));
}

SimdDecoder::SimdDecoder(const Decoder& d)
    : input_width_(d.input_width), num_outputs_(d.num_outputs()) {
    use_default_target_once();
    auto pad4 = [](int n) { return (n + 3) / 4 * 4; };
    output_half_ = pad4(num_outputs_);
    // Offsets first, then one aligned allocation.
    size_t size = 0;
    auto take = [&](size_t n) {
        size_t at = size;
        size += (n + 15) / 16 * 16;  // every array starts on 64 bytes
        return at;
    };
    scratch_ = 0;
    for (size_t l = 0; l < d.layers.size(); ++l) {
        const DenseLayer& L = d.layers[l];
        bool last = l + 1 == d.layers.size();
        Layer P;
        P.in = L.in;
        P.out_pad = last ? 2 * output_half_ : pad4(L.out);
        P.softplus = L.softplus;
        P.weight = take(size_t(P.in) * P.out_pad);
        P.bias = take(size_t(P.out_pad) + kSlack);
        scratch_ = std::max(scratch_, P.out_pad);
        layers_.push_back(P);
    }
    size += kSlack;
    data_.reset(static_cast<float*>(
        ::operator new[](size * sizeof(float), std::align_val_t(64))));
    std::fill(data_.get(), data_.get() + size, 0.f);
    for (size_t l = 0; l < d.layers.size(); ++l) {
        const DenseLayer& L = d.layers[l];
        const Layer& P = layers_[l];
        bool last = l + 1 == d.layers.size();
        // Row o of W goes to packed output slot o, except in the last layer, where the
        // log-variance rows (o >= num_outputs) move to the second half.
        for (int o = 0; o < L.out; ++o) {
            int slot = last && o >= num_outputs_ ? o - num_outputs_ + output_half_ : o;
            for (int i = 0; i < L.in; ++i)
                data_[P.weight + size_t(i) * P.out_pad + slot] =
                    L.weight[size_t(o) * L.in + i];
            data_[P.bias + slot] = L.bias[o];
        }
    }
}

void SimdDecoder::evaluate(const float* x, float* mean, float* logvar, int count) const {
    HWY_DYNAMIC_DISPATCH(EvaluateNet)(this, count, x, mean, logvar);
}

void SimdDecoder::sample_encoded(const float* x, const float* eps, float* u,
                                 int count) const {
    HWY_DYNAMIC_DISPATCH(SampleNet)(this, count, x, eps, u);
}

void SimdDecoder::sample_lanes(const float* x, const float* eps, float* u,
                               int count) const {
    HWY_DYNAMIC_DISPATCH(SampleLanes)(this, x, eps, u, count);
}

void code_lanes(const Encoding& e, bool decode, const float* in, float* out, int n,
                DecoderImpl impl) {
    if (impl == DecoderImpl::Simd) {
        HWY_DYNAMIC_DISPATCH(CodeLanes)(&e, decode, in, out, n);
        return;
    }
    for (int i = 0; i < n; ++i) out[i] = decode ? e.decode(in[i]) : e.encode(in[i]);
}

void draw_normal_uniforms(Rng& rng, int n, float* xr, float* xa) {
    const int pairs = (n + 1) / 2, blocks = (pairs + 3) / 4;
    for (int b = 0; b < blocks; ++b) {
        int k = std::min(4, pairs - 4 * b);
        for (int j = 0; j < 4; ++j) xr[4 * b + j] = j < k ? rng.uniform() : 0.f;
        for (int j = 0; j < 4; ++j) xa[4 * b + j] = j < k ? rng.uniform() : 0.f;
    }
}

void box_muller(const float* xr, const float* xa, float* c, float* s, int lanes,
                DecoderImpl impl) {
    if (impl == DecoderImpl::Simd) {
        HWY_DYNAMIC_DISPATCH(BoxMuller)(xr, xa, c, s, lanes);
        return;
    }
    for (int i = 0; i < lanes; ++i) {
        float r = std::sqrt(-2.f * std::log(1.f - xr[i]));
        float a = kTwoPi * xa[i];
        c[i] = r * std::cos(a);
        s[i] = r * std::sin(a);
    }
}

void assemble_normals(const float* c, const float* s, int n, float* z) {
    const int pairs = (n + 1) / 2, blocks = (pairs + 3) / 4;
    for (int b = 0, out = 0; b < blocks; ++b) {
        int k = std::min(4, pairs - 4 * b);
        for (int j = 0; j < k && out < n; ++j) z[out++] = c[4 * b + j];
        for (int j = 0; j < k && out < n; ++j) z[out++] = s[4 * b + j];
    }
}

void sample_normals(Rng& rng, float* z, int n, DecoderImpl impl) {
    constexpr int kChunk = 128;  // normals per call, a multiple of 8 (whole blocks)
    HWY_ALIGN float xr[kChunk / 2 + kSlack], xa[kChunk / 2 + kSlack],
        c[kChunk / 2 + kSlack], s[kChunk / 2 + kSlack];
    for (int done = 0; done < n; done += kChunk) {
        int m = std::min(n - done, kChunk), lanes = normal_lanes(m);
        draw_normal_uniforms(rng, m, xr, xa);
        box_muller(xr, xa, c, s, lanes, impl);
        assemble_normals(c, s, m, z + done);
    }
}

void softplus_simd(const float* x, float* y, size_t n) {
    HWY_ALIGN float buf[64 + kSlack];
    for (size_t i = 0; i < n; i += 64) {
        size_t m = std::min<size_t>(64, n - i);
        std::fill(buf, buf + 64, 0.f);
        std::copy(x + i, x + i + m, buf);
        HWY_DYNAMIC_DISPATCH(SoftplusArray)(buf, 64);
        std::copy(buf, buf + m, y + i);
    }
}

namespace {

// The targets compiled in that this CPU runs, best first. Read once, while no target is
// pinned (pin_target asks first, after unpinning): a pin narrows Highway's own list to
// the pinned target, and simd_targets() listed only that one after the decoders' first
// use.
const std::vector<int64_t>& runnable_targets() {
    static const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
    return targets;
}

// Pins `name` ("": every target this CPU has, the best chosen).
void pin_target(const std::string& name) {
    hwy::SetSupportedTargetsForTest(0);  // the real CPU again
    int64_t mask = 0;
    std::string allowed;
    for (int64_t t : runnable_targets()) {
        if (name == hwy::TargetName(t)) mask = t;
        allowed +=
            (allowed.empty() ? "'" : ", '") + std::string(hwy::TargetName(t)) + "'";
    }
    if (!name.empty() && mask == 0)
        fail("SIMD target '", name, "' is not available here (allowed: ", allowed, ")");
    hwy::SetSupportedTargetsForTest(mask);
    hwy::GetChosenTarget().Update(hwy::SupportedTargets());
}

// The default target, pinned once before the decoders first run (SimdDecoder's
// constructor) or are asked about.
void use_default_target_once() {
    static std::once_flag once;
    std::call_once(once, [] { pin_target(simd_default_target()); });
}

}  // namespace

const char* simd_target_name() {
    use_default_target_once();
    return HWY_DYNAMIC_DISPATCH(TargetName)();
}

std::vector<std::string> simd_targets() {
    std::vector<std::string> names;
    for (int64_t t : runnable_targets()) names.push_back(hwy::TargetName(t));
    return names;
}

void simd_use_target(const std::string& name) {
    use_default_target_once();
    pin_target(name.empty() ? simd_default_target() : name);
}

CpuId this_cpu_id() {
    CpuId id;
#if defined(__x86_64__) || defined(__i386__)
    unsigned a = 0, b = 0, c = 0, d = 0;
    if (__get_cpuid(0, &a, &b, &c, &d))
        id.intel =
            b == 0x756e6547u && d == 0x49656e69u && c == 0x6c65746eu;  // GenuineIntel
    if (__get_cpuid(1, &a, &b, &c, &d)) {
        const int family = int((a >> 8) & 0xf), model = int((a >> 4) & 0xf);
        id.family = family == 0xf ? family + int((a >> 20) & 0xff) : family;
        id.model = family == 6 || family == 0xf ? model | int((a >> 12) & 0xf0) : model;
    }
#endif
    return id;
}

std::string default_simd_target(const CpuId& cpu,
                                const std::vector<std::string>& available) {
    if (available.empty()) return "";
    const bool throttles =
        cpu.intel && cpu.family == 6 && (cpu.model == 85 || cpu.model == 167);
    if (throttles && available.front() == "AVX3")
        for (const std::string& t : available)
            if (t == "AVX2") return t;
    return available.front();
}

std::string simd_default_target() {
    static const std::string name = default_simd_target(this_cpu_id(), simd_targets());
    return name;
}

}  // namespace sss
#endif  // HWY_ONCE

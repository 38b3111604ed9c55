// The SIMD decoder: the same network as evaluate_reference (nn/decoder.h), evaluated on
// 4-wide blocks with Highway (libhwy-dev). Compiled for the x86-64-v2 baseline (Highway's
// SSSE3 target: its SSE4 target also wants AES and CLMUL) and for SSE4, AVX2+FMA and
// AVX-512, chosen at run time (Highway's dynamic dispatch). The results agree with the
// scalar reference to ~1e-6 relative (FMA and a different summation order, nothing else).
//
// Layout: each layer's weights are stored transposed, column j (the weights of input j
// for every output) contiguous and padded with zeros to out_pad = a multiple of 4
// outputs, so that y[o .. o+4) += W^T[j][o .. o+4) * x[j] is one 4-wide multiply-add;
// wider ISAs take 8 or 16 outputs of the same column at once. Softplus and exp(logvar /
// 2) run on the padded blocks. The last layer's rows are reordered to [means, 0..,
// log-variances, 0..], each half padded to a multiple of 4, so both halves start on a
// block.
//
// sample_lanes reads the same packed weights one at a time and broadcasts each over a row
// of 16 paths ("paths in lanes"): the form the sphere step uses (ScatteringModel::
// sample_group), cheapest per step when many paths need the network at once.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "nn/decoder.h"

namespace sss {

// Which evaluator a sampler uses: the scalar reference or the SIMD decoder.
enum class DecoderImpl { Scalar, Simd };

class SimdDecoder {
public:
    explicit SimdDecoder(const Decoder& d);

    int input_width() const { return input_width_; }
    int num_outputs() const { return num_outputs_; }

    // mean and logvar (num_outputs() each) for the input x (input_width() floats); with
    // count > 1, for `count` inputs one after the other (and outputs likewise). Several
    // inputs per call run faster per input: their dependency chains overlap
    // (bench/README.md).
    void evaluate(const float* x, float* mean, float* logvar, int count = 1) const;
    // The encoded output sample u_i = mean_i + exp(logvar_i / 2) eps_i (num_outputs()
    // each), for `count` inputs as above.
    void sample_encoded(const float* x, const float* eps, float* u, int count = 1) const;

    // Paths in lanes: the same samples u for up to kLanes inputs stored variable by
    // variable, x[i * kLanes + k] being input i of path k (likewise eps and u, rows of
    // num_outputs()). Lanes from `count` on are computed too (any finite values there are
    // harmless) or left alone. Every weight is a broadcast multiply-add on a vector of
    // paths, so the layers' dependency chains of all paths run side by side: the fastest
    // form when several paths need the network at once (bench/README.md).
    static constexpr int kLanes = 16;
    void sample_lanes(const float* x, const float* eps, float* u, int count) const;

    // The packed network, for the kernels (simd_decoder.cpp).
    struct Layer {
        int in = 0, out_pad = 0;  // out_pad: the padded output count (a multiple of 4)
        bool softplus = false;
        size_t weight = 0, bias = 0;  // offsets into data(): in x out_pad, out_pad floats
    };
    const std::vector<Layer>& layers() const { return layers_; }
    const float* data() const { return data_.get(); }
    int output_half() const { return output_half_; }  // offset of the log-variances
    int scratch_floats() const { return scratch_; }  // activation buffer size (each of 2)

    // Deleter of the 64-byte aligned arrays the kernels use.
    struct FreeAligned {
        void operator()(float* p) const;
    };

private:
    int input_width_ = 0, num_outputs_ = 0, output_half_ = 0, scratch_ = 0;
    std::vector<Layer> layers_;
    std::unique_ptr<float[], FreeAligned> data_;
};

// Standard normals z[0 .. n) from rng, by Box-Muller on blocks of at most 4 pairs: a
// block of k pairs draws 2k uniforms xi_0 .. xi_{2k-1} and, for j < k, with r_j = sqrt(-2
// ln(1 - xi_j)) and a_j = 2 pi xi_{k+j}, sets z_j = r_j cos a_j and z_{k+j} = r_j sin
// a_j. Blocks of 4 pairs follow each other; an odd n discards the last sine. Both
// implementations consume the same uniforms and agree to float rounding (|z| <= sqrt(2 ln
// 2^24) = 5.77: xi has 24 bits).
class Rng;
void sample_normals(Rng& rng, float* z, int n, DecoderImpl impl);

// sample_normals in three stages, so that the normals of several paths can share one
// vector call: the lanes that n normals take (4 per block), drawing their uniforms
// (radius and angle lanes; unused lanes get 0), Box-Muller on any number of lanes (a
// multiple of 4), and putting the results of one path's lanes in order.
inline int normal_lanes(int n) { return 4 * ((n + 7) / 8); }
void draw_normal_uniforms(Rng& rng, int n, float* xr, float* xa);
void box_muller(const float* xr, const float* xa, float* c, float* s, int lanes,
                DecoderImpl impl);
void assemble_normals(const float* c, const float* s, int n, float* z);

// The encoding e(x) (decode = false) or its inverse (true) of n <= SimdDecoder::kLanes
// values, in float; the scalar form is Encoding::encode / decode (double inside).
void code_lanes(const Encoding& e, bool decode, const float* in, float* out, int n,
                DecoderImpl impl);

// PyTorch's Softplus on x[0 .. n) with the decoder's SIMD kernel (for tests and
// benchmarks).
void softplus_simd(const float* x, float* y, size_t n);

// The Highway target the SIMD code runs on here ("AVX2", "AVX3", "SSE4", ...).
const char* simd_target_name();
// The targets compiled into the SIMD decoder that this CPU can run, best first, and a way
// to pin one of them ("" returns to the default, simd_default_target). For tests and
// benchmarks that cover every target; not thread-safe: call it only while no other thread
// uses the decoders.
std::vector<std::string> simd_targets();
void simd_use_target(const std::string& name);

// What the default target depends on: x86's vendor, family and model (CPUID leaf 1).
struct CpuId {
    bool intel = false;
    int family = 0, model = 0;
};
CpuId this_cpu_id();  // zeros on other architectures
// The decoders' default target on `cpu` among `available` (best first): the best, except
// AVX2 where the best is AVX-512 ("AVX3") on Intel's family 6, model 85 (Skylake-SP,
// Cascade Lake, Cooper Lake) and model 167 (Rocket Lake). Those cores lower their clock
// for about a millisecond after 512-bit floating-point work, and a render samples steps
// more often than that, so the rest of it (the path loop, libm) runs slower: `st` is
// 7-10 % (model 85) and 1-8 % (model 167) faster with AVX2 there although AVX2's decoders
// alone are slower (bench/README.md, "Which CPU").
std::string default_simd_target(const CpuId& cpu,
                                const std::vector<std::string>& available);
// default_simd_target for this CPU; the decoders run on it until simd_use_target pins
// another.
std::string simd_default_target();

}  // namespace sss

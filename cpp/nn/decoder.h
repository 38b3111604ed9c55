// One conditional-VAE decoder (LengthGen, PathGen or EventGen; paper Table 1) as read
// from its model file (docs/model-format.md, format_version 1), and the scalar reference
// evaluation: plain float loops, std::exp / std::log1p. The SIMD evaluator
// (nn/simd_decoder.h) and the GLSL decoder are tested against `evaluate_reference`.
#pragma once

#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace sss {

// The file format this build reads (docs/model-format.md).
constexpr const char* kDecoderFormat = "sssphere-cvae-decoder";
constexpr int kDecoderFormatVersion = 1;
constexpr int kNotationVersion = 1;

// e(x), the value a network sees (conditions) or predicts (outputs), and its inverse.
//   affine: e = a x + b                  x = (e - b) / a
//   log:    e = a ln(s x + c) + b        x = (exp((e - b) / a) - c) / s      (domain s x
//   + c > 0) logit:  e = a ln((x - lo + eps) / (hi - x + eps)) + b
//           x = lo - eps + (hi - lo + 2 eps) / (1 + exp(-(e - b) / a))   (domain lo-eps <
//           x < hi+eps)
// Log and logit are evaluated in double (a bounded variable near its ends loses digits in
// float).
struct Encoding {
    enum class Kind { Affine, Log, Logit };
    Kind kind = Kind::Affine;
    float a = 1.f, b = 0.f, s = 1.f, c = 0.f;  // s, c used by Log only
    float lo = -1.f, hi = 1.f, eps = 0.f;      // used by Logit only

    bool in_domain(float x) const {
        switch (kind) {
            case Kind::Affine:
                return true;
            case Kind::Log:
                return s * x + c > 0.f;
            case Kind::Logit:
                return x > lo - eps && x < hi + eps;
        }
        return false;
    }
    // Undefined outside the domain: check in_domain first.
    float encode(float x) const {
        switch (kind) {
            case Kind::Affine:
                return a * x + b;
            case Kind::Log:
                return float(double(a) * std::log(double(s) * x + c) + b);
            case Kind::Logit:
                return float(double(a) * std::log((double(x) - lo + eps) /
                                                  (double(hi) - x + eps)) +
                             b);
        }
        return 0.f;
    }
    float decode(float e) const {
        switch (kind) {
            case Kind::Affine:
                return (e - b) / a;
            case Kind::Log:
                return float((std::exp((double(e) - b) / a) - c) / s);
            case Kind::Logit:
                return float(double(lo) - eps +
                             (double(hi) - lo + 2.0 * eps) /
                                 (1.0 + std::exp(-(double(e) - b) / a)));
        }
        return 0.f;
    }
};

// A named variable (condition or output) and its encoding.
struct EncodedVariable {
    std::string name;
    Encoding encoding;
};

// y = activation(W x + b) with W row-major: `out` rows of `in` numbers.
struct DenseLayer {
    int in = 0, out = 0;
    bool softplus =
        false;  // hidden layers: Softplus (PyTorch's, threshold 20); last: identity
    std::vector<float> weight;
    std::vector<float> bias;
};

// The training range [lo, hi] of one conditioning parameter (sigma, g or phi).
struct Range {
    double lo = 0, hi = 0;
    bool contains(double x) const { return x >= lo && x <= hi; }
};

struct Decoder {
    std::string source;  // the file it came from (or a description), for messages
    std::string name;    // "LengthGen", "PathGen", "EventGen"
    std::vector<EncodedVariable> conditions;
    int latent_dim = 0;
    int input_width = 0;  // conditions + latent rounded up to a multiple of 4
    std::vector<DenseLayer> layers;
    std::vector<EncodedVariable> outputs;
    // training.sigma / .g / .phi where present (others of the file's `training` are kept
    // only as text in `training_json`).
    std::vector<std::pair<std::string, Range>> training_ranges;
    std::string training_json = "{}";
    std::string metrics_json;  // empty if absent

    int num_conditions() const { return int(conditions.size()); }
    int num_outputs() const { return int(outputs.size()); }
    // The training range of `param`, or nullptr if the file gives none.
    const Range* training_range(const std::string& param) const;
};

// Reads and validates a decoder file. Throws sss::Error naming the file (and the field)
// for a missing or unreadable file, malformed JSON, another format or format_version,
// unknown keys, inconsistent layer shapes, non-finite numbers and unknown encodings.
Decoder load_decoder(const std::string& path);
// The same from text; `source` names it in messages.
Decoder parse_decoder(const std::string& json_text, const std::string& source);
// The model-file text of `d` (floats with 9 significant digits: parse_decoder gives them
// back bit for bit). Used by tests and tools that write fixtures from code.
std::string decoder_to_json(const Decoder& d);

// Scalar reference evaluation of the network: x has d.input_width entries (encoded
// conditions, latent z, zeros), mean and logvar d.num_outputs() each.
void evaluate_reference(const Decoder& d, const float* x, float* mean, float* logvar);

}  // namespace sss

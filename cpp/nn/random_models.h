// Random-weight decoders with the shapes of paper Table 1 (depth 2, widths 8 / 16 / 16,
// latent 2 / 5 / 5) and the encodings a trainer would plausibly write, for tests and
// benchmarks that must not depend on a trained model. Deterministic for a given seed.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "core/check.h"
#include "core/rng.h"
#include "nn/decoder.h"

namespace sss {

struct DecoderShape {
    const char* name;
    std::vector<const char*> conditions, outputs;
    int latent_dim, width, hidden_layers;
};

inline DecoderShape table1_shape(const std::string& name) {
    if (name == "LengthGen") return {"LengthGen", {"sigma", "g"}, {"N"}, 2, 8, 2};
    if (name == "PathGen")
        return {"PathGen", {"sigma", "g", "N"}, {"cos_theta", "alpha", "beta"}, 5, 16, 2};
    if (name == "EventGen")
        return {"EventGen",
                {"sigma", "g", "phi", "N", "cos_theta", "alpha", "beta"},
                {"X_x", "X_y", "X_z", "W_x", "W_y", "W_z"},
                5,
                16,
                2};
    fail("table1_shape: unknown decoder '", name, "'");
}

// ln(1 + sigma), g as is, ln(1 - phi + 1e-3), ln N; outputs: ln N, the rest affine.
inline Encoding plausible_encoding(const std::string& var) {
    Encoding e;
    if (var == "sigma") {
        e.kind = Encoding::Kind::Log;
        e.a = 0.5f;
        e.b = -1.f;
        e.c = 1.f;
    } else if (var == "phi") {
        e.kind = Encoding::Kind::Log;
        e.s = -1.f;
        e.c = 1.001f;
    } else if (var == "N") {
        e.kind = Encoding::Kind::Log;
        e.a = 0.5f;
    } else if (var == "g") {
        e.a = 2.f;
    }
    return e;
}

// Weights uniform in +-weight_scale * sqrt(3 / in) (unit variance per output for unit
// inputs); the last layer's log-variance biases at `logvar_bias`, the mean biases at 0
// except ln 10 for N (so that N is around 10).
inline Decoder random_decoder(const DecoderShape& shape, uint64_t seed,
                              float weight_scale = 1.f, float logvar_bias = -2.f) {
    Rng rng(0xdec0de, seed);
    auto uni = [&](float a) { return a * (2.f * rng.uniform() - 1.f); };
    Decoder d;
    d.source = std::string("random ") + shape.name;
    d.name = shape.name;
    for (const char* c : shape.conditions)
        d.conditions.push_back({c, plausible_encoding(c)});
    for (const char* o : shape.outputs) d.outputs.push_back({o, plausible_encoding(o)});
    d.latent_dim = shape.latent_dim;
    d.input_width = (d.num_conditions() + d.latent_dim + 3) / 4 * 4;
    int in = d.input_width;
    for (int l = 0; l <= shape.hidden_layers; ++l) {
        bool last = l == shape.hidden_layers;
        DenseLayer L;
        L.in = in;
        L.out = last ? 2 * d.num_outputs() : shape.width;
        L.softplus = !last;
        float a = weight_scale * std::sqrt(3.f / float(in));
        for (int k = 0; k < L.in * L.out; ++k) L.weight.push_back(uni(a));
        for (int o = 0; o < L.out; ++o) L.bias.push_back(uni(0.5f));
        if (last) {
            for (int o = 0; o < d.num_outputs(); ++o) {
                L.bias[o] = d.outputs[o].name == "N" ? 0.5f * std::log(10.f)
                                                     : 0.f;  // e = ln(N) / 2
                L.bias[d.num_outputs() + o] = logvar_bias;
            }
        }
        d.layers.push_back(std::move(L));
        in = shape.width;
    }
    d.training_ranges = {
        {"sigma", {0.0, 200.0}}, {"g", {-0.95, 0.95}}, {"phi", {0.0, 1.0}}};
    d.training_json = "{\"samples\": 0, \"note\": \"random weights for tests\"}";
    return d;
}

inline Decoder random_decoder(const std::string& name, uint64_t seed,
                              float weight_scale = 1.f, float logvar_bias = -2.f) {
    return random_decoder(table1_shape(name), seed, weight_scale, logvar_bias);
}

// Random-weight cut sphere decoders ("CutLengthGen", "CutPathGen": the shapes of
// spec.CUT_SPECS), "trained" for sigma in [0.5, 32], g in [-0.95, 0.95], h in [0.01, 1]
// and mu0 in [-1, 1].
inline Decoder random_cut_decoder(const std::string& name, uint64_t seed) {
    DecoderShape shape =
        name == "CutLengthGen"
            ? DecoderShape{"CutLengthGen", {"sigma", "g", "h", "mu0"}, {"N"}, 2, 16, 2}
            : DecoderShape{"CutPathGen",
                           {"sigma", "g", "h", "mu0", "N"},
                           {"cos_p", "cos_psi", "alpha", "beta"},
                           5,
                           32,
                           2};
    if (name != "CutLengthGen" && name != "CutPathGen")
        fail("random_cut_decoder: unknown decoder '", name, "'");
    Decoder d = random_decoder(shape, seed);
    d.training_ranges = {{"sigma", {0.5, 32.0}},
                         {"g", {-0.95, 0.95}},
                         {"h", {0.01, 1.0}},
                         {"mu0", {-1.0, 1.0}}};
    return d;
}

}  // namespace sss

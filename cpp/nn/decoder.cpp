#include "nn/decoder.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/check.h"
#include "core/files.h"
#include "io/json_fields.h"
#include "shared/softplus.h"

namespace sss {

const Range* Decoder::training_range(const std::string& param) const {
    for (const auto& [name, range] : training_ranges)
        if (name == param) return &range;
    return nullptr;
}

namespace {

using json = nlohmann::json;

// Largest layer width and latent size accepted: far above paper Table 1 (<= 20), low
// enough that a corrupt file cannot ask for gigabytes.
constexpr int64_t kMaxWidth = 4096;

using namespace json_fields;

// A float32 parameter (weight, bias, encoding constant): finite after rounding to float.
float float32(const json& j, const Field& f) {
    double v = number(j, f);
    float x = float(v);
    if (!std::isfinite(x)) f.error("value ", show(j), " is not a finite float32");
    return x;
}

const json& array_of(const json& j, const Field& f, size_t size, const char* what) {
    if (!j.is_array()) f.error("expected ", what, ", got ", type_name(j), " ", show(j));
    if (j.size() != size) f.error("expected ", what, ", got ", j.size(), " entries");
    return j;
}

Encoding parse_encoding(const json& j, const Field& f) {
    if (!j.is_object()) f.error("expected an object, got ", type_name(j), " ", show(j));
    std::string kind = string_of(require(j, "kind", f), f.at("kind"));
    Encoding e;
    if (kind == "affine") {
        check_keys(j, f, {"kind", "a", "b"});
        e.kind = Encoding::Kind::Affine;
    } else if (kind == "log") {
        check_keys(j, f, {"kind", "a", "b", "s", "c"});
        e.kind = Encoding::Kind::Log;
        if (j.contains("s")) e.s = float32(j["s"], f.at("s"));
        if (j.contains("c")) e.c = float32(j["c"], f.at("c"));
        if (e.s == 0.f)
            f.at("s").error("value 0 is not allowed (the encoding must be invertible)");
    } else if (kind == "logit") {
        check_keys(j, f, {"kind", "a", "b", "lo", "hi", "eps"});
        e.kind = Encoding::Kind::Logit;
        if (j.contains("lo")) e.lo = float32(j["lo"], f.at("lo"));
        if (j.contains("hi")) e.hi = float32(j["hi"], f.at("hi"));
        if (j.contains("eps")) e.eps = float32(j["eps"], f.at("eps"));
        if (!(e.eps >= 0.f))
            f.at("eps").error("value ", e.eps, " is not allowed (allowed: eps >= 0)");
        if (!(e.hi > e.lo))
            f.at("hi").error("value ", e.hi, " is not allowed (allowed: hi > lo = ", e.lo,
                             ")");
    } else {
        f.at("kind").error("unknown encoding kind \"", kind,
                           "\" (allowed: \"affine\", \"log\", \"logit\")");
    }
    if (j.contains("a")) e.a = float32(j["a"], f.at("a"));
    if (j.contains("b")) e.b = float32(j["b"], f.at("b"));
    if (e.a == 0.f)
        f.at("a").error("value 0 is not allowed (the encoding must be invertible)");
    return e;
}

std::vector<EncodedVariable> parse_variables(const json& j, const Field& f) {
    if (!j.is_array() || j.empty())
        f.error("expected a non-empty array of {\"name\", \"encode\"} objects, got ",
                show(j));
    std::vector<EncodedVariable> vars;
    std::set<std::string> seen;
    for (size_t i = 0; i < j.size(); ++i) {
        Field fi = f.at(i);
        check_keys(j[i], fi, {"name", "encode"});
        EncodedVariable v;
        v.name = string_of(require(j[i], "name", fi), fi.at("name"));
        if (!seen.insert(v.name).second)
            fi.at("name").error("duplicate name \"", v.name, "\"");
        v.encoding = parse_encoding(require(j[i], "encode", fi), fi.at("encode"));
        vars.push_back(std::move(v));
    }
    return vars;
}

DenseLayer parse_layer(const json& j, const Field& f, int expected_in, bool last) {
    check_keys(j, f, {"in", "out", "activation", "weight", "bias"});
    DenseLayer L;
    L.in = int(integer_in(require(j, "in", f), f.at("in"), 1, kMaxWidth, "1 to 4096"));
    L.out = int(integer_in(require(j, "out", f), f.at("out"), 1, kMaxWidth, "1 to 4096"));
    if (L.in != expected_in)
        f.at("in").error(
            "value ", L.in, " does not match the width of the previous layer's output (",
            expected_in, f.path == "layers[0]" ? ", the input_width" : "", ")");
    std::string act = string_of(require(j, "activation", f), f.at("activation"));
    const char* want = last ? "identity" : "softplus";
    if (act != "softplus" && act != "identity")
        f.at("activation")
            .error("unknown activation \"", act,
                   "\" (allowed: \"softplus\", \"identity\")");
    if (act != want)
        f.at("activation")
            .error("\"", act, "\" is not allowed here: hidden layers use \"softplus\", ",
                   "the last layer \"identity\"");
    L.softplus = !last;

    Field fw = f.at("weight");
    const json& w = array_of(require(j, "weight", f), fw, size_t(L.out), "'out' rows");
    L.weight.resize(size_t(L.out) * L.in);
    for (int o = 0; o < L.out; ++o) {
        const json& row =
            array_of(w[o], fw.at(size_t(o)), size_t(L.in), "a row of 'in' numbers");
        for (int i = 0; i < L.in; ++i)
            L.weight[size_t(o) * L.in + i] =
                float32(row[i], fw.at(size_t(o)).at(size_t(i)));
    }
    Field fb = f.at("bias");
    const json& b = array_of(require(j, "bias", f), fb, size_t(L.out), "'out' numbers");
    L.bias.resize(L.out);
    for (int o = 0; o < L.out; ++o) L.bias[o] = float32(b[o], fb.at(size_t(o)));
    return L;
}

std::string parse_error_hint(const std::string& text) {
    if (text.find("NaN") != std::string::npos ||
        text.find("Infinity") != std::string::npos)
        return " (NaN and Infinity are not JSON; every number in a model file must be "
               "finite)";
    return "";
}

}  // namespace

Decoder parse_decoder(const std::string& text, const std::string& source) {
    json j = parse_json(text, source, [&] { return parse_error_hint(text); });
    Field root{source, ""};
    if (!j.is_object()) root.error("expected a JSON object, got ", type_name(j));

    check_format(j, root, kDecoderFormat, kDecoderFormatVersion, "a decoder file");

    check_keys(j, root,
               {"format", "format_version", "notation_version", "name", "conditions",
                "latent_dim", "input_width", "layers", "outputs", "training", "metrics"});
    int64_t notation =
        integer_in(require(j, "notation_version", root), root.at("notation_version"), 0,
                   INT32_MAX, "a non-negative integer");
    if (notation != kNotationVersion)
        root.at("notation_version")
            .error("notation_version ", notation,
                   " is not supported (this build uses notation_version ",
                   kNotationVersion, ", docs/notation.md)");

    Decoder d;
    d.source = source;
    d.name = string_of(require(j, "name", root), root.at("name"));
    if (d.name.empty()) root.at("name").error("must not be empty");
    d.conditions = parse_variables(require(j, "conditions", root), root.at("conditions"));
    d.latent_dim = int(integer_in(require(j, "latent_dim", root), root.at("latent_dim"),
                                  0, kMaxWidth, "0 to 4096"));
    d.input_width =
        int(integer_in(require(j, "input_width", root), root.at("input_width"), 1,
                       2 * kMaxWidth, "1 to 8192"));
    int needed = d.num_conditions() + d.latent_dim;
    int padded = (needed + 3) / 4 * 4;
    if (d.input_width != padded)
        root.at("input_width")
            .error("value ", d.input_width,
                   " is not len(conditions) + latent_dim = ", d.num_conditions(), " + ",
                   d.latent_dim, " = ", needed, " rounded up to a multiple of 4 (",
                   padded, ")");
    d.outputs = parse_variables(require(j, "outputs", root), root.at("outputs"));

    const json& layers = require(j, "layers", root);
    Field fl = root.at("layers");
    if (!layers.is_array() || layers.empty())
        fl.error("expected a non-empty array of layers, got ", show(layers));
    int width = d.input_width;
    for (size_t i = 0; i < layers.size(); ++i) {
        d.layers.push_back(
            parse_layer(layers[i], fl.at(i), width, i + 1 == layers.size()));
        width = d.layers.back().out;
    }
    if (width != 2 * d.num_outputs())
        fl.at(layers.size() - 1)
            .at("out")
            .error("value ", width, " is not 2 x len(outputs) = ", 2 * d.num_outputs(),
                   " (the means, then the log-variances)");

    // training: free-form, except the ranges of the conditioning parameters.
    const json& training = require(j, "training", root);
    Field ft = root.at("training");
    if (!training.is_object()) ft.error("expected an object, got ", type_name(training));
    for (const char* param : {"sigma", "g", "phi", "h", "mu0"}) {
        bool is_condition = false;
        for (const auto& c : d.conditions) is_condition |= c.name == param;
        auto it = training.find(param);
        if (it == training.end()) {
            if (is_condition)
                ft.error("missing the range of condition '", param,
                         "' (an array [lo, hi])");
            continue;
        }
        Field fp = ft.at(param);
        array_of(*it, fp, 2, "a range [lo, hi]");
        Range r{number((*it)[0], fp.at(size_t(0))), number((*it)[1], fp.at(size_t(1)))};
        if (!(r.lo <= r.hi)) fp.error("empty range [", r.lo, ", ", r.hi, "]");
        d.training_ranges.emplace_back(param, r);
    }
    d.training_json = training.dump();
    if (j.contains("metrics")) {
        if (!j["metrics"].is_object())
            root.at("metrics").error("expected an object, got ", type_name(j["metrics"]));
        d.metrics_json = j["metrics"].dump();
    }
    return d;
}

Decoder load_decoder(const std::string& path) {
    if (std::filesystem::exists(path)) check_input_file(path, "model file");
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path, ": cannot open the model file (missing or unreadable)");
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) fail(path, ": cannot read the model file");
    return parse_decoder(text.str(), path);
}

namespace {

// A float with 9 significant digits: enough to read back the same float32.
std::string f9(float x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", double(x));
    return buf;
}

std::string encoding_json(const Encoding& e) {
    const char* kind = e.kind == Encoding::Kind::Affine ? "affine"
                       : e.kind == Encoding::Kind::Log  ? "log"
                                                        : "logit";
    std::string s = std::string("{\"kind\": \"") + kind + "\"";
    s += ", \"a\": " + f9(e.a) + ", \"b\": " + f9(e.b);
    if (e.kind == Encoding::Kind::Log) s += ", \"s\": " + f9(e.s) + ", \"c\": " + f9(e.c);
    if (e.kind == Encoding::Kind::Logit)
        s +=
            ", \"lo\": " + f9(e.lo) + ", \"hi\": " + f9(e.hi) + ", \"eps\": " + f9(e.eps);
    return s + "}";
}

std::string variables_json(const std::vector<EncodedVariable>& vars) {
    std::string s = "[";
    for (size_t i = 0; i < vars.size(); ++i)
        s += std::string(i ? ",\n    " : "\n    ") +
             "{\"name\": " + json(vars[i].name).dump() +
             ", \"encode\": " + encoding_json(vars[i].encoding) + "}";
    return s + "\n  ]";
}

}  // namespace

std::string decoder_to_json(const Decoder& d) {
    std::string s = "{\n";
    s += "  \"format\": \"" + std::string(kDecoderFormat) + "\",\n";
    s += "  \"format_version\": " + std::to_string(kDecoderFormatVersion) + ",\n";
    s += "  \"notation_version\": " + std::to_string(kNotationVersion) + ",\n";
    s += "  \"name\": " + json(d.name).dump() + ",\n";
    s += "  \"conditions\": " + variables_json(d.conditions) + ",\n";
    s += "  \"latent_dim\": " + std::to_string(d.latent_dim) + ",\n";
    s += "  \"input_width\": " + std::to_string(d.input_width) + ",\n";
    s += "  \"layers\": [";
    for (size_t l = 0; l < d.layers.size(); ++l) {
        const DenseLayer& L = d.layers[l];
        s += std::string(l ? "," : "") + "\n    {\"in\": " + std::to_string(L.in) +
             ", \"out\": " + std::to_string(L.out) + ", \"activation\": \"" +
             (L.softplus ? "softplus" : "identity") + "\",\n     \"weight\": [";
        for (int o = 0; o < L.out; ++o) {
            s += o ? ",\n                [" : "[";
            for (int i = 0; i < L.in; ++i)
                s += (i ? ", " : "") + f9(L.weight[size_t(o) * L.in + i]);
            s += "]";
        }
        s += "],\n     \"bias\": [";
        for (int o = 0; o < L.out; ++o) s += (o ? ", " : "") + f9(L.bias[o]);
        s += "]}";
    }
    s += "\n  ],\n";
    s += "  \"outputs\": " + variables_json(d.outputs) + ",\n";
    json training = json::parse(d.training_json);
    for (const auto& [name, r] : d.training_ranges) training[name] = {r.lo, r.hi};
    s += "  \"training\": " + training.dump();
    if (!d.metrics_json.empty()) s += ",\n  \"metrics\": " + d.metrics_json;
    return s + "\n}\n";
}

void evaluate_reference(const Decoder& d, const float* x, float* mean, float* logvar) {
    size_t widest = size_t(d.input_width);
    for (const DenseLayer& L : d.layers) widest = std::max(widest, size_t(L.out));
    // Two activation buffers, on the stack for the small networks this is made for.
    float stack[2][64];
    std::vector<float> heap;
    float *a = stack[0], *b = stack[1];
    if (widest > 64) {
        heap.resize(2 * widest);
        a = heap.data();
        b = heap.data() + widest;
    }
    std::copy(x, x + d.input_width, a);
    for (const DenseLayer& L : d.layers) {
        for (int o = 0; o < L.out; ++o) {
            const float* w = &L.weight[size_t(o) * L.in];
            float acc = L.bias[o];
            for (int i = 0; i < L.in; ++i) acc += w[i] * a[i];
            b[o] = L.softplus ? softplus(acc) : acc;
        }
        std::swap(a, b);
    }
    int n = d.num_outputs();
    std::copy(a, a + n, mean);
    std::copy(a + n, a + 2 * n, logvar);
}

}  // namespace sss

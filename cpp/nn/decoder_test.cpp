#include "nn/decoder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>

#include "core/check.h"
#include "nn/random_models.h"
#include "shared/softplus.h"
#include "testing/errors.h"
#include "testing/temp_file.h"

namespace sss {
namespace {

using json = nlohmann::json;

using test::error_of;

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(Decoder, JsonRoundTripIsExact) {
    for (const char* name : {"LengthGen", "PathGen", "EventGen"}) {
        Decoder d = random_decoder(name, 7);
        d.metrics_json = "{\"latent_in_use\":2}";
        Decoder e = parse_decoder(decoder_to_json(d), "round trip");
        EXPECT_EQ(e.name, d.name);
        EXPECT_EQ(e.latent_dim, d.latent_dim);
        EXPECT_EQ(e.input_width, d.input_width);
        ASSERT_EQ(e.layers.size(), d.layers.size());
        for (size_t l = 0; l < d.layers.size(); ++l) {
            const DenseLayer &a = d.layers[l], &b = e.layers[l];
            EXPECT_EQ(a.in, b.in);
            EXPECT_EQ(a.out, b.out);
            EXPECT_EQ(a.softplus, b.softplus);
            for (size_t k = 0; k < a.weight.size(); ++k)
                ASSERT_TRUE(same_bits(a.weight[k], b.weight[k])) << k;
            for (size_t k = 0; k < a.bias.size(); ++k)
                ASSERT_TRUE(same_bits(a.bias[k], b.bias[k])) << k;
        }
        ASSERT_EQ(e.conditions.size(), d.conditions.size());
        for (size_t i = 0; i < d.conditions.size(); ++i) {
            EXPECT_EQ(e.conditions[i].name, d.conditions[i].name);
            const Encoding &a = d.conditions[i].encoding, &b = e.conditions[i].encoding;
            EXPECT_EQ(a.kind, b.kind);
            EXPECT_TRUE(same_bits(a.a, b.a) && same_bits(a.b, b.b) &&
                        same_bits(a.s, b.s) && same_bits(a.c, b.c));
        }
        ASSERT_EQ(e.outputs.size(), d.outputs.size());
        ASSERT_NE(e.training_range("sigma"), nullptr);
        EXPECT_EQ(e.training_range("sigma")->hi, 200.0);
        EXPECT_EQ(e.training_range("g")->lo, -0.95);
        EXPECT_EQ(json::parse(e.metrics_json), json::parse(d.metrics_json));
        EXPECT_EQ(json::parse(e.training_json)["note"], "random weights for tests");
        // Same file text again: the writer is a fixed point.
        EXPECT_EQ(decoder_to_json(e), decoder_to_json(d));
    }
}

TEST(Decoder, EncodingsRoundTrip) {
    struct Case {
        Encoding e;
        std::vector<float> xs;
    };
    Encoding affine{Encoding::Kind::Affine, 2.5f, -0.75f, 1.f, 0.f};
    Encoding log1p_sigma{Encoding::Kind::Log, 0.5f, -1.f, 1.f, 1.f};  // a ln(1 + x) + b
    Encoding log_n{Encoding::Kind::Log, 1.f, 0.f, 1.f, 0.f};          // ln N
    Encoding log_phi{Encoding::Kind::Log, -0.3f, 0.2f, -1.f,
                     1.001f};                               // ln(1 - phi + eps)
    Encoding logit_cos{Encoding::Kind::Logit, 0.7f, 0.1f};  // cos theta in [-1, 1]
    logit_cos.eps = 1e-4f;
    std::vector<Case> cases = {
        {affine, {-3.f, -1.f, 0.f, 0.3f, 7.f, 150.f}},
        {logit_cos, {-1.f, -0.999f, -0.3f, 0.f, 0.5f, 0.9999f, 1.f}},
        {log1p_sigma, {0.f, 0.01f, 1.f, 10.f, 200.f}},
        {log_n, {2.f, 3.f, 57.f, 1e6f}},
        {log_phi, {0.f, 0.5f, 0.99f, 1.f}}};
    for (const Case& c : cases) {
        for (float x : c.xs) {
            ASSERT_TRUE(c.e.in_domain(x)) << x;
            float e = c.e.encode(x);
            double want =
                c.e.kind == Encoding::Kind::Affine ? double(c.e.a) * x + c.e.b
                : c.e.kind == Encoding::Kind::Log
                    ? double(c.e.a) * std::log(double(c.e.s) * x + double(c.e.c)) + c.e.b
                    : double(c.e.a) *
                              std::log((double(x) + 1.0 + 1e-4) / (1.0 - x + 1e-4)) +
                          c.e.b;
            EXPECT_NEAR(e, want, 1e-6 * std::max(1.0, std::abs(want))) << x;
            float back = c.e.decode(e);
            EXPECT_NEAR(back, x, 2e-5 * std::max(1.f, std::abs(x))) << x;
        }
    }
    EXPECT_FALSE(log_n.in_domain(0.f));
    EXPECT_FALSE(log_n.in_domain(-1.f));
    EXPECT_FALSE(log_phi.in_domain(1.01f));
    EXPECT_TRUE(affine.in_domain(-1e30f));
    EXPECT_FALSE(logit_cos.in_domain(1.001f));
    EXPECT_FALSE(logit_cos.in_domain(-1.001f));
}

TEST(Decoder, ReferenceEvaluationFollowsTheFormula) {
    // A 4 -> 3 (softplus) -> 2 network by hand.
    Decoder d = random_decoder("LengthGen", 3);
    d.layers = {{4, 3, true, {1, 0, 0, 0, 0, 2, 0, 0, -1, 1, 1, 1}, {0.5f, 0.f, 30.f}},
                {3, 2, false, {1, 1, 1, 0, 0, 2}, {0.f, -1.f}}};
    float x[4] = {1.f, -2.f, 3.f, 0.25f};
    float mean, logvar;
    evaluate_reference(d, x, &mean, &logvar);
    float h0 = std::log1p(std::exp(1.5f)), h1 = std::log1p(std::exp(-4.f)),
          h2 = 30.f + 0.25f;  // > 20: identity
    EXPECT_FLOAT_EQ(mean, h0 + h1 + h2);
    EXPECT_FLOAT_EQ(logvar, 2.f * h2 - 1.f);
}

TEST(Decoder, SoftplusIsTorchs) {
    EXPECT_EQ(softplus(20.5f), 20.5f);
    EXPECT_EQ(softplus(1000.f), 1000.f);
    EXPECT_FLOAT_EQ(softplus(20.f), std::log1p(std::exp(20.f)));
    EXPECT_FLOAT_EQ(softplus(0.f), std::log(2.f));
    EXPECT_FLOAT_EQ(softplus(-30.f), std::exp(-30.f));
}

// ---- Load errors
// ---------------------------------------------------------------------------

class DecoderFile : public ::testing::Test {
protected:
    json valid() { return json::parse(decoder_to_json(random_decoder("PathGen", 1))); }
    // The message of loading `text` from a temporary file, which it must name.
    std::string load_text_error(const std::string& text) {
        test::TempFile f("model.json", text);
        std::string msg = error_of([&] { load_decoder(f.path()); });
        EXPECT_NE(msg.find(f.path()), std::string::npos)
            << "message does not name the file: " << msg;
        return msg;
    }
    std::string load_error(const json& j) { return load_text_error(j.dump()); }
};

TEST_F(DecoderFile, ValidFileLoads) {
    test::TempFile f("model.json", valid().dump());
    Decoder d = load_decoder(f.path());
    EXPECT_EQ(d.name, "PathGen");
    EXPECT_EQ(d.source, f.path());
}

TEST_F(DecoderFile, MissingOrUnreadable) {
    std::string missing =
        (std::filesystem::temp_directory_path() / "sss_no_such_model.json").string();
    std::string msg = error_of([&] { load_decoder(missing); });
    EXPECT_HAS(msg, missing);
    EXPECT_HAS(msg, "cannot open");
    std::string dir = std::filesystem::temp_directory_path().string();
    msg = error_of([&] { load_decoder(dir); });
    EXPECT_HAS(msg, dir);
}

TEST_F(DecoderFile, MalformedJson) {
    EXPECT_HAS(load_text_error("{\"format\": \"sssphere-cvae-decoder\", "),
               "malformed JSON");
    EXPECT_HAS(load_text_error(""), "malformed JSON");
    std::string nan = valid().dump();
    nan.replace(nan.find("\"bias\":[") + 8, 0, "NaN, ");
    EXPECT_HAS(load_text_error(nan), "NaN and Infinity are not JSON");
    EXPECT_HAS(load_text_error("[1, 2]"), "expected a JSON object");
}

TEST_F(DecoderFile, WrongFormatOrVersion) {
    json j = valid();
    j["format"] = "sssphere-scene";
    std::string msg = load_error(j);
    EXPECT_HAS(msg, "\"sssphere-scene\"");
    EXPECT_HAS(msg, "\"sssphere-cvae-decoder\"");

    j = valid();
    j["format_version"] = 2;
    msg = load_error(j);
    EXPECT_HAS(msg, "format_version 2 is not supported");
    EXPECT_HAS(msg, "reads format_version 1");

    j = valid();
    j.erase("format_version");
    EXPECT_HAS(load_error(j), "missing required key 'format_version'");
    j = valid();
    j.erase("format");
    EXPECT_HAS(load_error(j), "missing required key 'format'");
    j = valid();
    j["notation_version"] = 3;
    EXPECT_HAS(load_error(j), "notation_version 3 is not supported");
}

TEST_F(DecoderFile, UnknownOrMissingKeys) {
    json j = valid();
    j["learning_rate"] = 0.1;
    EXPECT_HAS(load_error(j), "unknown key 'learning_rate'");
    j = valid();
    j["layers"][1]["dropout"] = 0.1;
    EXPECT_HAS(load_error(j), "layers[1].dropout: unknown key");
    j = valid();
    j.erase("training");
    EXPECT_HAS(load_error(j), "missing required key 'training'");
    j = valid();
    j["training"].erase("g");
    EXPECT_HAS(load_error(j), "missing the range of condition 'g'");
    j = valid();
    j["training"]["sigma"] = {200, 0};
    EXPECT_HAS(load_error(j), "training.sigma: empty range");
    // Free-form entries of `training` and `metrics` are kept, not rejected.
    j = valid();
    j["training"]["epochs"] = 40;
    j["metrics"] = {{"kl", 0.3}};
    test::TempFile f("model.json", j.dump());
    EXPECT_NO_THROW(load_decoder(f.path()));
}

TEST_F(DecoderFile, InconsistentShapes) {
    json j = valid();
    j["input_width"] = 12;
    EXPECT_HAS(load_error(j),
               "input_width: value 12 is not len(conditions) + latent_dim = 3 + 5 = 8");
    j = valid();
    j["latent_dim"] = 6;  // 3 + 6 = 9 -> 12, but input_width says 8
    EXPECT_HAS(load_error(j), "rounded up to a multiple of 4 (12)");
    j = valid();
    j["layers"][1]["in"] = 15;
    EXPECT_HAS(load_error(j), "layers[1].in: value 15 does not match");
    j = valid();
    j["layers"][0]["weight"].erase(0);
    EXPECT_HAS(load_error(j), "layers[0].weight: expected 'out' rows, got 15 entries");
    j = valid();
    j["layers"][2]["weight"][3].erase(0);
    EXPECT_HAS(load_error(j), "layers[2].weight[3]: expected a row of 'in' numbers");
    j = valid();
    j["layers"][1]["bias"].push_back(0.0);
    EXPECT_HAS(load_error(j), "layers[1].bias: expected 'out' numbers, got 17 entries");
    j = valid();
    j["outputs"].erase(2);
    EXPECT_HAS(load_error(j), "is not 2 x len(outputs) = 4");
    j = valid();
    j["layers"][2]["activation"] = "softplus";
    EXPECT_HAS(load_error(j), "layers[2].activation: \"softplus\" is not allowed here");
    j = valid();
    j["layers"][0]["activation"] = "relu";
    EXPECT_HAS(load_error(j), "unknown activation \"relu\"");
    j = valid();
    j["layers"] = json::array();
    EXPECT_HAS(load_error(j), "expected a non-empty array of layers");
    j = valid();
    j["layers"][0]["weight"][0][0] = "1.0";
    EXPECT_HAS(load_error(j), "layers[0].weight[0][0]: expected a number, got a string");
}

TEST_F(DecoderFile, NonFiniteNumbers) {
    json j = valid();
    j["layers"][1]["weight"][2][5] = 1e39;  // finite in JSON, infinite as float32
    EXPECT_HAS(load_error(j),
               "layers[1].weight[2][5]: value 1e+39 is not a finite float32");
    j = valid();
    j["layers"][2]["bias"][0] = -3.5e38;
    EXPECT_HAS(load_error(j), "layers[2].bias[0]");
    j = valid();
    j["outputs"][0]["encode"]["a"] = 1e300;
    EXPECT_HAS(load_error(j), "outputs[0].encode.a");
    std::string text = valid().dump();
    text.replace(text.find("\"bias\":[") + 8, 0, "Infinity, ");
    EXPECT_HAS(load_text_error(text), "must be finite");
}

TEST_F(DecoderFile, BadEncodings) {
    json j = valid();
    j["conditions"][0]["encode"] = {{"kind", "sqrt"}};
    EXPECT_HAS(load_error(j),
               "conditions[0].encode.kind: unknown encoding kind \"sqrt\"");
    j = valid();
    j["conditions"][1]["encode"] = {{"kind", "affine"}, {"s", 2}};
    EXPECT_HAS(load_error(j), "conditions[1].encode.s: unknown key 's'");
    j = valid();
    j["outputs"][1]["encode"] = {{"kind", "affine"}, {"a", 0}};
    EXPECT_HAS(load_error(j), "outputs[1].encode.a: value 0 is not allowed");
    j = valid();
    j["conditions"][2]["encode"] = {{"kind", "log"}, {"s", 0}};
    EXPECT_HAS(load_error(j), "conditions[2].encode.s: value 0 is not allowed");
    j = valid();
    j["conditions"][0].erase("encode");
    EXPECT_HAS(load_error(j), "conditions[0]: missing required key 'encode'");
    j = valid();
    j["conditions"][1]["name"] = "sigma";
    EXPECT_HAS(load_error(j), "duplicate name \"sigma\"");
    // Defaults: a = 1, b = 0, s = 1, c = 0.
    j = valid();
    j["conditions"][2]["encode"] = {{"kind", "log"}};
    test::TempFile f("model.json", j.dump());
    Encoding e = load_decoder(f.path()).conditions[2].encoding;
    EXPECT_EQ(e.kind, Encoding::Kind::Log);
    EXPECT_EQ(e.a, 1.f);
    EXPECT_EQ(e.b, 0.f);
    EXPECT_EQ(e.s, 1.f);
    EXPECT_EQ(e.c, 0.f);
}

}  // namespace
}  // namespace sss

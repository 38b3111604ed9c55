#include "nn/scattering_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/check.h"
#include "nn/random_models.h"
#include "shared/sphere_step.h"
#include "testing/errors.h"

namespace sss {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

using test::error_of;

ScatteringModel random_model(uint64_t seed = 1, float scale = 1.f) {
    return ScatteringModel(random_decoder("LengthGen", seed, scale),
                           random_decoder("PathGen", seed, scale),
                           random_decoder("EventGen", seed, scale), "random");
}

// The tilt (a, b) at every (sigma, g).
StepTilt constant_tilt(float a, float b) {
    StepTilt t;
    t.log_sigma = {0.f};
    t.g = {0.f};
    t.a = {a};
    t.b = {b};
    t.source = "constant";
    return t;
}

bool same(const SphereStep& a, const SphereStep& b) {
    return a.N == b.N && std::memcmp(&a.cos_theta, &b.cos_theta, sizeof(float)) == 0 &&
           std::memcmp(&a.alpha, &b.alpha, sizeof(float)) == 0 &&
           std::memcmp(&a.beta, &b.beta, sizeof(float)) == 0 &&
           std::memcmp(&a.X, &b.X, sizeof(Vec3)) == 0 &&
           std::memcmp(&a.W, &b.W, sizeof(Vec3)) == 0;
}

// A directory of model files that is removed at the end of the test.
class ModelDir {
public:
    ModelDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ =
            fs::temp_directory_path() /
            (std::string("sss_models_") + info->test_suite_name() + "_" + info->name());
        fs::create_directories(path_);
    }
    ~ModelDir() { fs::remove_all(path_); }
    void write(const std::string& file, const std::string& text) {
        std::ofstream(path_ / file) << text;
    }
    void write_random(uint64_t seed = 1) {
        write("lengthgen.json", decoder_to_json(random_decoder("LengthGen", seed)));
        write("pathgen.json", decoder_to_json(random_decoder("PathGen", seed)));
        write("eventgen.json", decoder_to_json(random_decoder("EventGen", seed)));
    }
    std::string path() const { return path_.string(); }
    std::string file(const std::string& f) const { return (path_ / f).string(); }

private:
    fs::path path_;
};

TEST(ScatteringModel, LoadsADirectory) {
    ModelDir dir;
    dir.write_random();
    ScatteringModel m = ScatteringModel::load(dir.path());
    EXPECT_EQ(m.length_gen().name, "LengthGen");
    EXPECT_EQ(m.decoder("pathgen").name, "PathGen");
    EXPECT_EQ(m.decoder("EventGen").source, dir.file("eventgen.json"));
    EXPECT_EQ(m.sigma_range().hi, 200.0);
    EXPECT_HAS(error_of([&] { m.decoder("SizeGen"); }), "no decoder named 'SizeGen'");
    // Same samples as the decoders built in memory.
    ScatteringModel r = random_model();
    for (int i = 0; i < 50; ++i) {
        Rng a(1, i), b(1, i);
        EXPECT_TRUE(same(m.sample(5.f, 0.3f, 0.9f, a), r.sample(5.f, 0.3f, 0.9f, b)));
    }
}

TEST(ScatteringModel, LoadErrors) {
    ModelDir dir;
    EXPECT_HAS(error_of([&] { ScatteringModel::load(dir.file("nowhere")); }),
               "not a directory");
    dir.write("lengthgen.json", decoder_to_json(random_decoder("LengthGen", 1)));
    dir.write("pathgen.json", decoder_to_json(random_decoder("PathGen", 1)));
    std::string msg = error_of([&] { ScatteringModel::load(dir.path()); });
    EXPECT_HAS(msg, dir.file("eventgen.json"));
    EXPECT_HAS(msg, "cannot open");

    // A decoder in the wrong file.
    dir.write("eventgen.json", decoder_to_json(random_decoder("PathGen", 1)));
    msg = error_of([&] { ScatteringModel::load(dir.path()); });
    EXPECT_HAS(msg, dir.file("eventgen.json"));
    EXPECT_HAS(msg, "name \"PathGen\" where EventGen was expected");

    // Conditions in another order.
    json j = json::parse(decoder_to_json(random_decoder("PathGen", 1)));
    std::swap(j["conditions"][0], j["conditions"][1]);
    dir.write("eventgen.json", decoder_to_json(random_decoder("EventGen", 1)));
    dir.write("pathgen.json", j.dump());
    EXPECT_HAS(error_of([&] { ScatteringModel::load(dir.path()); }),
               "conditions [g, sigma, N] where PathGen has [sigma, g, N]");

    // An encoding undefined for values the step produces: ln(1 + cos_theta) at cos_theta
    // = -1.
    dir.write("pathgen.json", decoder_to_json(random_decoder("PathGen", 1)));
    j = json::parse(decoder_to_json(random_decoder("EventGen", 1)));
    j["conditions"][4]["encode"] = {{"kind", "log"}, {"c", 1}};
    dir.write("eventgen.json", j.dump());
    msg = error_of([&] { ScatteringModel::load(dir.path()); });
    EXPECT_HAS(msg, "the encoding of 'cos_theta'");
    // ln(2 - N) is undefined for every N >= 2.
    j = json::parse(decoder_to_json(random_decoder("PathGen", 1)));
    j["conditions"][2]["encode"] = {{"kind", "log"}, {"s", -1}, {"c", 3}};
    dir.write("eventgen.json", decoder_to_json(random_decoder("EventGen", 1)));
    dir.write("pathgen.json", j.dump());
    EXPECT_HAS(error_of([&] { ScatteringModel::load(dir.path()); }),
               "the encoding of 'N'");
}

TEST(ScatteringModel, InputsOutsideTheTrainingRangesAreErrors) {
    ScatteringModel m = random_model();
    Rng rng(1);
    std::string msg = error_of([&] { m.sample(250.f, 0.f, 0.5f, rng); });
    EXPECT_HAS(msg, "sigma = 250 is outside the training range [0, 200] of LengthGen");
    EXPECT_HAS(msg, "shrinks the sphere");
    EXPECT_HAS(error_of([&] { m.sample(-1.f, 0.f, 0.5f, rng); }),
               "sigma = -1 is not allowed");
    EXPECT_HAS(error_of([&] { m.sample(NAN, 0.f, 0.5f, rng); }),
               "sigma = nan is not allowed");
    EXPECT_HAS(error_of([&] { m.sample(INFINITY, 0.f, 0.5f, rng); }),
               "sigma = inf is not allowed");
    EXPECT_HAS(error_of([&] { m.sample(1.f, 0.97f, 0.5f, rng); }),
               "g = 0.97 is outside the training range [-0.95, 0.95]");
    EXPECT_HAS(error_of([&] { m.sample(1.f, -1.f, 0.5f, rng); }),
               "g = -1 is not allowed");
    EXPECT_HAS(error_of([&] { m.sample(1.f, 0.f, 1.5f, rng); }),
               "phi = 1.5 is not allowed");
    // A narrower phi range in EventGen matters only when the event is sampled.
    Decoder e = random_decoder("EventGen", 1);
    e.training_ranges[2].second = {0.5, 1.0};
    ScatteringModel n(random_decoder("LengthGen", 1), random_decoder("PathGen", 1), e);
    EXPECT_HAS(error_of([&] { n.sample(1.f, 0.f, 0.2f, rng, true); }),
               "phi = 0.2 is outside the training range [0.5, 1] of EventGen");
    EXPECT_NO_THROW(n.sample(1.f, 0.f, 0.2f, rng, false));
    // The batch names the index.
    std::vector<float> sigma = {1.f, 2.f, 300.f}, g = {0.f, 0.f, 0.f},
                       phi = {1.f, 1.f, 1.f};
    std::vector<SphereStep> out(3);
    EXPECT_HAS(error_of([&] {
                   m.sample_batch(sigma.data(), g.data(), phi.data(), 3, 0, 1, true,
                                  DecoderImpl::Simd, out.data());
               }),
               "sigma[2] = 300 is outside");
}

// P(N = 1) = e^{-sigma}, exactly: a binomial test at 4.5 standard deviations for each
// sigma.
TEST(ScatteringModel, SingleScatteringHasProbabilityExpMinusSigma) {
    ScatteringModel m = random_model();
    const size_t n = 40000;
    for (float sigma : {0.f, 0.05f, 0.5f, 1.f, 2.f, 4.f}) {
        std::vector<float> s(n, sigma), g(n, 0.4f), phi(n, 0.9f);
        std::vector<SphereStep> out(n);
        m.sample_batch(s.data(), g.data(), phi.data(), n, 12, 0, false, DecoderImpl::Simd,
                       out.data());
        double ones = 0;
        for (const SphereStep& st : out) ones += st.N == 1;
        double p = std::exp(-double(sigma));
        EXPECT_NEAR(ones / n, p, 4.5 * std::sqrt(p * (1 - p) / n) + 1e-12)
            << "sigma = " << sigma;
    }
}

// For N >= 2 the centre is the representative event with probability (1 - phi)/(1 -
// phi^N) (1/N for phi = 1), drawn exactly: count X = 0 against the sum of those
// probabilities.
TEST(ScatteringModel, FirstEventIsChosenWithItsExactProbability) {
    ScatteringModel m = random_model();
    const size_t n = 40000;
    for (float phi : {0.f, 0.5f, 0.99f, 1.f}) {
        std::vector<float> s(n, 3.f), g(n, 0.2f), ph(n, phi);
        std::vector<SphereStep> out(n);
        m.sample_batch(s.data(), g.data(), ph.data(), n, 21, 0, true, DecoderImpl::Simd,
                       out.data());
        double expected = 0, var = 0, centre = 0;
        for (const SphereStep& st : out) {
            if (st.N < 2) continue;
            double N = double(st.N);
            double p =
                phi >= 1.f ? 1.0 / N : (1.0 - phi) / (1.0 - std::pow(double(phi), N));
            expected += p;
            var += p * (1 - p);
            centre += st.X == Vec3(0.f) && st.W == Vec3(0.f, 0.f, 1.f);
        }
        EXPECT_NEAR(centre, expected, 4.5 * std::sqrt(var) + 1e-9) << "phi = " << phi;
    }
}

// N = 1: the exit follows the first HG direction (mean cosine g), nothing else moves.
TEST(ScatteringModel, SingleScatteringIsExact) {
    ScatteringModel m = random_model();
    for (float g : {-0.8f, 0.f, 0.6f}) {
        double sum = 0, sum2 = 0;
        int count = 0;
        for (uint64_t i = 0; i < 20000; ++i) {
            Rng rng(4, i);
            SphereStep s = m.sample(0.01f, g, 0.5f, rng, true);
            if (s.N != 1) continue;
            EXPECT_EQ(s.alpha, 0.f);
            EXPECT_EQ(s.beta, 0.f);
            EXPECT_EQ(s.X, Vec3(0.f));
            EXPECT_EQ(s.W, Vec3(0.f, 0.f, 1.f));
            sum += s.cos_theta;
            sum2 += double(s.cos_theta) * s.cos_theta;
            ++count;
        }
        double mean = sum / count, var = sum2 / count - mean * mean;
        EXPECT_NEAR(mean, g, 4.5 * std::sqrt(var / count)) << "g = " << g;
    }
}

// The post-processing of docs/model-format.md holds whatever the networks say: models
// with large weights and variances produce raw values far outside every range.
TEST(ScatteringModel, PostProcessingInvariants) {
    for (float scale : {1.f, 8.f}) {
        for (float logvar : {-2.f, 3.f}) {
            Decoder l = random_decoder("LengthGen", 2, scale, logvar);
            Decoder p = random_decoder("PathGen", 2, scale, logvar);
            Decoder e = random_decoder("EventGen", 2, scale, logvar);
            ScatteringModel m(l, p, e);
            size_t clamped_cos = 0, scaled_ab = 0, scaled_x = 0, n2 = 0;
            for (uint64_t i = 0; i < 4000; ++i) {
                Rng rng(8, i);
                float sigma = 200.f * rng.uniform(), g = 1.9f * rng.uniform() - 0.95f,
                      phi = rng.uniform();
                for (DecoderImpl impl : {DecoderImpl::Scalar, DecoderImpl::Simd}) {
                    SphereStep s = m.sample(sigma, g, phi, rng, true, impl);
                    ASSERT_GE(s.N, 1);
                    ASSERT_LE(s.N, kMaxScatterCount);
                    ASSERT_LE(std::abs(s.cos_theta), 1.f);
                    ASSERT_LE(s.alpha * s.alpha + s.beta * s.beta, 1.f);
                    ASSERT_LE(dot(s.X, s.X), 1.f);
                    ASSERT_NEAR(length(s.W), 1.f, 1e-6f);
                    ASSERT_TRUE(std::isfinite(s.cos_theta) && std::isfinite(s.alpha) &&
                                is_finite(s.X) && is_finite(s.W));
                    clamped_cos += std::abs(s.cos_theta) == 1.f;
                    scaled_ab +=
                        std::abs(s.alpha * s.alpha + s.beta * s.beta - 1.f) < 1e-6f;
                    scaled_x += std::abs(length(s.X) - 1.f) < 1e-6f;
                    n2 += s.N == 2;
                }
            }
            if (scale == 8.f && logvar == 3.f) {  // every rule was exercised
                EXPECT_GT(clamped_cos, 100u);
                EXPECT_GT(scaled_ab, 100u);
                EXPECT_GT(scaled_x, 100u);
                EXPECT_GT(n2, 100u);
            }
        }
    }
}

// Without the event, X and W keep their N = 1 values and fewer random numbers are used.
TEST(ScatteringModel, EventIsOptional) {
    ScatteringModel m = random_model();
    for (uint64_t i = 0; i < 200; ++i) {
        Rng a(2, i), b(2, i);
        SphereStep with = m.sample(20.f, 0.2f, 0.7f, a, true),
                   without = m.sample(20.f, 0.2f, 0.7f, b, false);
        EXPECT_EQ(with.N, without.N);
        EXPECT_EQ(with.cos_theta, without.cos_theta);
        EXPECT_EQ(with.alpha, without.alpha);
        EXPECT_EQ(without.X, Vec3(0.f));
        EXPECT_EQ(without.W, Vec3(0.f, 0.f, 1.f));
    }
}

// Scalar and SIMD sampling consume the same random numbers and agree to float rounding;
// N, a floor, may differ only where the scalar value sits within rounding of an integer.
TEST(ScatteringModel, ScalarAndSimdSamplesAgree) {
    ScatteringModel m = random_model(3);
    int n_differs = 0, total = 0;
    double worst = 0;
    for (uint64_t i = 0; i < 5000; ++i) {
        Rng param(9, i);
        float sigma = 1.f + 100.f * param.uniform(), g = 1.8f * param.uniform() - 0.9f,
              phi = param.uniform();
        Rng a(10, i), b(10, i);
        SphereStep s = m.sample(sigma, g, phi, a, true, DecoderImpl::Scalar);
        SphereStep v = m.sample(sigma, g, phi, b, true, DecoderImpl::Simd);
        EXPECT_EQ(a.next_u32(), b.next_u32());
        ++total;
        if (s.N != v.N) {
            ++n_differs;
            EXPECT_LE(std::abs(s.N - v.N), 1);
            continue;
        }
        float d[] = {s.cos_theta - v.cos_theta, s.alpha - v.alpha, s.beta - v.beta,
                     length(s.X - v.X), length(s.W - v.W)};
        for (float x : d) worst = std::max(worst, double(std::abs(x)));
    }
    EXPECT_LE(n_differs, total / 500);
    EXPECT_LT(worst, 1e-4);
    RecordProperty("max_abs_diff", std::to_string(worst * 1e6) + "e-6");
    RecordProperty("n_differs", n_differs);
}

// A group of steps gives the same samples, bit for bit, as the steps one at a time,
// whatever the group size (past 16, in several evaluations) and however many of its
// steps take the N = 1 shortcut.
//
// With a tilt too: its refusals draw some steps of a group again (a strong one here, so
// that many are).
TEST(ScatteringModel, GroupEqualsSingleSteps) {
    ScatteringModel m = random_model(5);
    for (bool tilted : {false, true}) {
        if (tilted) m.set_tilt(constant_tilt(0.6f, -0.25f));
        for (DecoderImpl impl : {DecoderImpl::Simd, DecoderImpl::Scalar}) {
            for (int K : {1, 3, 8, 16, 40, 64}) {
                for (bool event : {false, true}) {
                    float sigma[64], g[64], phi[64];
                    Rng param(3, K);
                    for (int k = 0; k < K; ++k) {
                        sigma[k] = k % 3 == 0 ? 0.2f : 30.f * param.uniform();
                        g[k] = 1.8f * param.uniform() - 0.9f;
                        phi[k] = param.uniform();
                    }
                    std::vector<Rng> group, single;
                    for (int k = 0; k < K; ++k) {
                        group.emplace_back(21, K, k);
                        single.emplace_back(21, K, k);
                    }
                    SphereStep out[64];
                    m.sample_group(K, sigma, g, phi, group.data(), event, impl, out);
                    for (int k = 0; k < K; ++k) {
                        EXPECT_TRUE(same(out[k], m.sample(sigma[k], g[k], phi[k],
                                                          single[k], event, impl)))
                            << K << " " << k << " tilted " << tilted;
                        EXPECT_EQ(group[k].next_u32(), single[k].next_u32());
                    }
                }
            }
        }
    }
    float s = 300.f, g = 0.f, phi = 0.5f;
    Rng rng(1);
    SphereStep out;
    EXPECT_HAS(error_of([&] {
                   m.sample_group(1, &s, &g, &phi, &rng, true, DecoderImpl::Simd, &out);
               }),
               "sigma[0] = 300");
    EXPECT_HAS(error_of([&] {
                   m.sample_group(65, &s, &g, &phi, &rng, true, DecoderImpl::Simd, &out);
               }),
               "count 65");
}

TEST(ScatteringModel, BatchIsIndependentOfThreadCount) {
    ScatteringModel m = random_model(4);
    const size_t n = 3001;
    std::vector<float> sigma(n), g(n), phi(n);
    Rng rng(6);
    for (size_t i = 0; i < n; ++i) {
        sigma[i] = 8.f * rng.uniform();
        g[i] = 1.8f * rng.uniform() - 0.9f;
        phi[i] = rng.uniform();
    }
    for (DecoderImpl impl : {DecoderImpl::Simd, DecoderImpl::Scalar}) {
        std::vector<SphereStep> one(n), many(n);
        m.sample_batch(sigma.data(), g.data(), phi.data(), n, 77, 1, true, impl,
                       one.data());
        for (int threads : {2, 3, 8, 0}) {
            m.sample_batch(sigma.data(), g.data(), phi.data(), n, 77, threads, true, impl,
                           many.data());
            for (size_t i = 0; i < n; ++i)
                ASSERT_TRUE(same(one[i], many[i]))
                    << "threads " << threads << " sample " << i;
        }
        // Sample i is the single step drawn with Rng(seed, i).
        for (size_t i = 0; i < n; i += 97) {
            Rng r(77, i);
            EXPECT_TRUE(same(one[i], m.sample(sigma[i], g[i], phi[i], r, true, impl)))
                << i;
        }
    }
}

// The tilt reweights the decoders' steps by 1 + a cos_theta + b w_z
// (shared/sphere_step.h): the tilted steps' means of cos_theta and w_z are the untilted
// steps' weighted means, to within five standard errors of the difference (both from the
// samples). Steps with N = 1 are exact and left alone (sigma 1.5: a fifth of them).
TEST(ScatteringModel, TiltReweightsTheDecodersSteps) {
    ScatteringModel m = random_model(8);
    const size_t n = 200000;
    const float a = 0.5f, b = 0.3f;
    for (float sigma : {1.5f, 12.f}) {
        std::vector<float> s(n, sigma), g(n, 0.4f), phi(n, 0.9f);
        std::vector<SphereStep> plain(n), tilted(n);
        m.set_tilt(StepTilt());
        m.sample_batch(s.data(), g.data(), phi.data(), n, 5, 0, false, DecoderImpl::Simd,
                       plain.data());
        m.set_tilt(constant_tilt(a, b));
        m.sample_batch(s.data(), g.data(), phi.data(), n, 6, 0, false, DecoderImpl::Simd,
                       tilted.data());
        auto w_z = [](const SphereStep& st) {
            return double(sphere_exit_direction(st.cos_theta, st.alpha, st.beta).z);
        };
        // The untilted steps' means with the networks' steps (N >= 2) weighted, those
        // with N = 1 as they are (the tilt keeps their share), the tilted steps' plain
        // means, and their variances for the standard errors.
        double m1 = 0, w1 = 0, swm = 0, sww = 0, sw = 0, p1 = 0;
        double tm = 0, tw = 0, tm2 = 0, tw2 = 0, ones = 0;
        for (size_t i = 0; i < n; ++i) {
            const SphereStep& p = plain[i];
            if (p.N == 1) {
                p1 += 1, m1 += p.cos_theta, w1 += w_z(p);
            } else {
                const double w = 1.0 + a * p.cos_theta + b * w_z(p);
                sw += w, swm += w * p.cos_theta, sww += w * w_z(p);
            }
            const SphereStep& t = tilted[i];
            tm += t.cos_theta, tw += w_z(t);
            tm2 += double(t.cos_theta) * t.cos_theta, tw2 += w_z(t) * w_z(t);
            ones += t.N == 1;
        }
        const double want_m = (m1 + (n - p1) * swm / sw) / n,
                     want_w = (w1 + (n - p1) * sww / sw) / n;
        tm /= n, tw /= n;
        const double se_m = std::sqrt(2 * (tm2 / n - tm * tm) / n),
                     se_w = std::sqrt(2 * (tw2 / n - tw * tw) / n);
        EXPECT_NEAR(tm, want_m, 5 * se_m) << sigma;
        EXPECT_NEAR(tw, want_w, 5 * se_w) << sigma;
        // The tilt moves the means by much more than that (the test can fail).
        double pm = 0;
        for (const SphereStep& p : plain) pm += p.cos_theta;
        EXPECT_GT(std::abs(tm - pm / n), 10 * se_m) << sigma;
        if (sigma < 2.f) {
            EXPECT_NEAR(ones / n, std::exp(-1.5), 0.01);
        }
    }
}

TEST(StepTilt, InterpolatesInLogSigmaAndG) {
    StepTilt t;
    t.log_sigma = {std::log(2.f), std::log(8.f)};
    t.g = {0.f, 0.5f, 0.9f};
    t.a = {0.f, 0.2f, 0.1f, 0.3f, 0.4f, 0.4f};  // rows of g: (0, 0.2), (0.1, 0.3), ...
    t.b = {0.f, -0.2f, 0.f, 0.f, 0.f, 0.f};
    float a, b;
    t.at(4.f, 0.f, &a, &b);  // halfway in ln sigma
    EXPECT_NEAR(a, 0.1f, 1e-6f);
    EXPECT_NEAR(b, -0.1f, 1e-6f);
    t.at(2.f, 0.25f, &a, &b);
    EXPECT_NEAR(a, 0.05f, 1e-6f);
    t.at(8.f, 0.7f, &a, &b);
    EXPECT_NEAR(a, 0.35f, 1e-6f);
    t.at(1000.f, 0.99f, &a, &b);  // clamped at the outer nodes
    EXPECT_NEAR(a, 0.4f, 1e-6f);
    t.at(0.5f, -0.9f, &a, &b);
    EXPECT_EQ(a, 0.f);
    StepTilt().at(4.f, 0.f, &a, &b);
    EXPECT_EQ(a, 0.f);
    EXPECT_EQ(b, 0.f);
}

TEST(StepTilt, LoadsBesideTheModelsAndNamesWhatIsWrong) {
    ModelDir dir;
    dir.write_random();
    const std::string good =
        R"({"format": "sssphere-step-tilt", "format_version": 1, "sigma": [3, 30],
            "g": [0, 0.9], "a": [[0, 0.1], [0.2, 0.3]], "b": [[0, 0], [0, -0.1]]})";
    dir.write("tilt.json", good);
    EXPECT_FALSE(ScatteringModel::load(dir.path()).tilt().empty());
    EXPECT_TRUE(ScatteringModel::load(dir.path(), false).tilt().empty());
    float a, b;
    ScatteringModel::load(dir.path()).tilt().at(30.f, 0.9f, &a, &b);
    EXPECT_FLOAT_EQ(a, 0.3f);
    EXPECT_FLOAT_EQ(b, -0.1f);

    auto error = [&](const std::string& text) {
        dir.write("tilt.json", text);
        return error_of([&] { ScatteringModel::load(dir.path()); });
    };
    auto with = [&](const std::string& from, const std::string& to) {
        std::string t = good;
        t.replace(t.find(from), from.size(), to);
        return error(t);
    };
    EXPECT_HAS(with("step-tilt", "cvae-decoder"), "is not a tilt file");
    EXPECT_HAS(with("\"format_version\": 1", "\"format_version\": 2"),
               "format_version 2 is not supported");
    EXPECT_HAS(with("[3, 30]", "[30, 3]"), "sigma[1]: value 3 is not above the node");
    EXPECT_HAS(with("[3, 30]", "[0, 30]"), "allowed: 0 < sigma");
    EXPECT_HAS(with("[0, 0.9]", "[0, 1]"), "allowed: -1 < g < 1");
    EXPECT_HAS(with("[[0, 0.1], [0.2, 0.3]]", "[[0, 0.1]]"),
               "expected an array of 2 rows");
    EXPECT_HAS(with("[0.2, 0.3]", "[0.2, 0.95]"), "a[1][1]: |a| + |b| = 1.05");
    EXPECT_HAS(with("[0.2, 0.3]", "[0.2, \"x\"]"), "a[1][1]: expected a number");
    EXPECT_HAS(with("\"b\":", "\"c\": 1, \"b\":"), "unknown key 'c'");
    EXPECT_HAS(error("{"), "tilt.json: malformed JSON");
}

}  // namespace
}  // namespace sss

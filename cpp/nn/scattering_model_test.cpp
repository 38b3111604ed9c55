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
// whatever the group size and however many of its steps take the N = 1 shortcut.
TEST(ScatteringModel, GroupEqualsSingleSteps) {
    ScatteringModel m = random_model(5);
    for (DecoderImpl impl : {DecoderImpl::Simd, DecoderImpl::Scalar}) {
        for (int K : {1, 3, 8, 16}) {
            for (bool event : {false, true}) {
                float sigma[16], g[16], phi[16];
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
                SphereStep out[16];
                m.sample_group(K, sigma, g, phi, group.data(), event, impl, out);
                for (int k = 0; k < K; ++k) {
                    EXPECT_TRUE(same(
                        out[k], m.sample(sigma[k], g[k], phi[k], single[k], event, impl)))
                        << K << " " << k;
                    EXPECT_EQ(group[k].next_u32(), single[k].next_u32());
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
                   m.sample_group(17, &s, &g, &phi, &rng, true, DecoderImpl::Simd, &out);
               }),
               "count 17");
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

}  // namespace
}  // namespace sss

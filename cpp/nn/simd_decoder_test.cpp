#include "nn/simd_decoder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <vector>

#include "core/rng.h"
#include "nn/random_models.h"
#include "shared/softplus.h"

namespace sss {
namespace {

// Symmetric relative error of a against b; below `floor` in magnitude it is
// absolute/floor.
double rel_err(double a, double b, double floor = 1e-30) {
    return std::abs(a - b) / std::max({std::abs(a), std::abs(b), floor});
}

// Runs body once for every SIMD target compiled in and supported here (SSE4 at least, the
// build's baseline), then returns to the default one.
template <class F>
void for_each_target(F&& body) {
    std::vector<std::string> targets = simd_targets();
    ASSERT_FALSE(targets.empty());
    for (const std::string& t : targets) {
        simd_use_target(t);
        SCOPED_TRACE("SIMD target " + t);
        EXPECT_EQ(std::string(simd_target_name()), t);
        body();
    }
    simd_use_target("");
}

// The x86-64-v2 baseline compiles Highway's SSSE3 target (its SSE4 target also wants AES
// and CLMUL, which v2 lacks); one of the two always runs, and the default target is
// chosen.
TEST(SimdDecoder, TargetsIncludeTheBaseline) {
    std::vector<std::string> targets = simd_targets();
    ASSERT_FALSE(targets.empty());
    bool baseline = std::find(targets.begin(), targets.end(), "SSSE3") != targets.end() ||
                    std::find(targets.begin(), targets.end(), "SSE4") != targets.end();
    EXPECT_TRUE(baseline);
    EXPECT_EQ(std::string(simd_target_name()), simd_default_target());
    EXPECT_NE(std::find(targets.begin(), targets.end(), simd_default_target()),
              targets.end());
}

// Pinning a target changes which one runs, not the list of those this CPU can run (the
// list once shrank to the pinned target, so after the decoders' first use it held only
// the default).
TEST(SimdDecoder, PinningATargetKeepsTheListOfTargets) {
    const std::vector<std::string> before = simd_targets();
    for (const std::string& t : before) {
        simd_use_target(t);
        EXPECT_EQ(simd_targets(), before) << "after pinning " << t;
    }
    simd_use_target("");
    EXPECT_EQ(simd_targets(), before);
}

// The best target, except AVX2 instead of AVX-512 on Intel's family 6, models 85 and 167.
TEST(SimdDecoder, DefaultTargetAvoidsAvx512WhereItLowersTheClock) {
    const std::vector<std::string> all = {"AVX3", "AVX2", "SSE4"};
    EXPECT_EQ(default_simd_target({true, 6, 85}, all), "AVX2");    // Cascade Lake
    EXPECT_EQ(default_simd_target({true, 6, 167}, all), "AVX2");   // Rocket Lake
    EXPECT_EQ(default_simd_target({true, 6, 106}, all), "AVX3");   // Ice Lake-SP
    EXPECT_EQ(default_simd_target({true, 6, 143}, all), "AVX3");   // Sapphire Rapids
    EXPECT_EQ(default_simd_target({false, 25, 97}, all), "AVX3");  // AMD Zen 4
    EXPECT_EQ(default_simd_target({true, 6, 85}, {"AVX2", "SSE4"}), "AVX2");
    EXPECT_EQ(default_simd_target({true, 6, 85}, {"AVX3", "SSE4"}), "AVX3");  // no AVX2
    EXPECT_EQ(default_simd_target({true, 6, 85}, {}), "");
    // This CPU's default is the rule applied to its own id and targets.
    EXPECT_EQ(simd_default_target(), default_simd_target(this_cpu_id(), simd_targets()));
}

// Scalar reference and SIMD decoder on random inputs for random-weight models of each
// Table-1 shape. Weight scales up to 6 push pre-activations well past Softplus' threshold
// of 20 and deep into its exponential tail. The error of each output is measured relative
// to the larger of its two values and the root-mean-square of that output over the batch:
// an output that cancels to near zero is judged on the scale of its typical values
// (summation order and FMA move it by a few float ulps of the terms, not of the sum).
TEST(SimdDecoder, MatchesScalarReference) {
    for_each_target([] {
        for (const char* name : {"LengthGen", "PathGen", "EventGen"}) {
            for (float scale : {0.5f, 1.f, 3.f, 6.f}) {
                Decoder d = random_decoder(name, 11, scale);
                SimdDecoder s(d);
                const int n = 2000, no = d.num_outputs();
                std::vector<float> ref(2 * no * n), got(2 * no * n);
                Rng rng(5, uint64_t(scale * 10));
                for (int k = 0; k < n; ++k) {
                    std::vector<float> x(d.input_width);
                    for (float& v : x) v = 6.f * rng.uniform() - 3.f;
                    evaluate_reference(d, x.data(), &ref[2 * no * k],
                                       &ref[2 * no * k + no]);
                    s.evaluate(x.data(), &got[2 * no * k], &got[2 * no * k + no]);
                }
                std::vector<double> rms(2 * no, 0.0);
                for (int k = 0; k < n; ++k)
                    for (int i = 0; i < 2 * no; ++i)
                        rms[i] += double(ref[2 * no * k + i]) * ref[2 * no * k + i] / n;
                double worst = 0, worst_plain = 0;
                for (int k = 0; k < n; ++k) {
                    for (int i = 0; i < 2 * no; ++i) {
                        float a = got[2 * no * k + i], b = ref[2 * no * k + i];
                        worst = std::max(worst, rel_err(a, b, std::sqrt(rms[i])));
                        worst_plain = std::max(worst_plain, rel_err(a, b));
                    }
                }
                EXPECT_LT(worst, 1e-5) << name << " weight scale " << scale;
                std::ostringstream os;
                os << std::setprecision(2) << worst << " (plain relative: " << worst_plain
                   << ")";
                RecordProperty(std::string(simd_target_name()) + "_" + name + "_scale" +
                                   std::to_string(scale),
                               os.str());
            }
        }
    });
}

// Several inputs per call give exactly the results of one input per call.
TEST(SimdDecoder, ManyInputsPerCallEqualOneAtATime) {
    for_each_target([] {
        for (const char* name : {"LengthGen", "PathGen", "EventGen"}) {
            Decoder d = random_decoder(name, 4, 2.f);
            SimdDecoder s(d);
            const int K = 16, w = d.input_width, no = d.num_outputs();
            std::vector<float> x(K * w), mean(K * no), logvar(K * no), eps(K * no),
                u(K * no);
            Rng rng(12);
            for (float& v : x) v = 6.f * rng.uniform() - 3.f;
            for (float& v : eps) v = 2.f * rng.uniform() - 1.f;
            for (int count : {2, 5, 16}) {
                s.evaluate(x.data(), mean.data(), logvar.data(), count);
                s.sample_encoded(x.data(), eps.data(), u.data(), count);
                for (int k = 0; k < count; ++k) {
                    float m1[8], l1[8], u1[8];
                    s.evaluate(&x[k * w], m1, l1);
                    s.sample_encoded(&x[k * w], &eps[k * no], u1);
                    for (int i = 0; i < no; ++i) {
                        EXPECT_EQ(m1[i], mean[k * no + i])
                            << name << " " << count << " " << k;
                        EXPECT_EQ(l1[i], logvar[k * no + i]);
                        EXPECT_EQ(u1[i], u[k * no + i]);
                    }
                }
            }
        }
    });
}

// Paths in lanes (one row of kLanes floats per variable) give the samples of the
// one-input-per-call layout to float rounding (another summation order), for every count
// of paths.
TEST(SimdDecoder, LanesMatchOneInputPerCall) {
    constexpr int L = SimdDecoder::kLanes;
    for_each_target([] {
        for (const char* name : {"LengthGen", "PathGen", "EventGen"}) {
            Decoder d = random_decoder(name, 6, 2.f);
            SimdDecoder s(d);
            const int w = d.input_width, no = d.num_outputs();
            alignas(64) float x[32 * L], eps[8 * L], u[8 * L];
            Rng rng(13);
            for (int count : {1, 5, 16}) {
                for (float& v : x) v = 6.f * rng.uniform() - 3.f;
                for (float& v : eps) v = 2.f * rng.uniform() - 1.f;
                s.sample_lanes(x, eps, u, count);
                for (int k = 0; k < count; ++k) {
                    float xk[32], ek[8], uk[8];
                    for (int i = 0; i < w; ++i) xk[i] = x[i * L + k];
                    for (int i = 0; i < no; ++i) ek[i] = eps[i * L + k];
                    s.sample_encoded(xk, ek, uk);
                    for (int i = 0; i < no; ++i)
                        EXPECT_NEAR(u[i * L + k], uk[i],
                                    1e-5f * std::max(1.f, std::abs(uk[i])))
                            << name << " count " << count << " lane " << k;
                }
            }
        }
    });
}

// The encodings on lanes (float) agree with the scalar ones (double inside).
TEST(SimdDecoder, EncodingsOnLanesMatchScalar) {
    constexpr int L = SimdDecoder::kLanes;
    Encoding affine{Encoding::Kind::Affine, 2.5f, -0.3f};
    Encoding log{Encoding::Kind::Log, 0.69f, -1.66f, 1.f, 0.5f};
    Encoding log_neg{Encoding::Kind::Log, 1.03f, 0.36f, -1.f, 1.f};
    Encoding logit{Encoding::Kind::Logit, 0.47f, -0.18f, 1.f, 0.f, -1.f, 1.f, 1e-4f};
    for_each_target([&] {
        for (const Encoding* e : {&affine, &log, &log_neg, &logit}) {
            Rng rng(17);
            for (int rep = 0; rep < 50; ++rep) {
                alignas(64) float x[L], enc[L], dec[L];
                for (float& v : x) {
                    v = 1.998f * rng.uniform() - 0.999f;  // in every domain above
                    if (e == &log) v = 200.f * rng.uniform();
                }
                code_lanes(*e, false, x, enc, L, DecoderImpl::Simd);
                code_lanes(*e, true, enc, dec, L, DecoderImpl::Simd);
                for (int k = 0; k < L; ++k) {
                    EXPECT_NEAR(enc[k], e->encode(x[k]),
                                2e-6f * std::max(1.f, std::abs(enc[k])));
                    EXPECT_NEAR(dec[k], e->decode(enc[k]),
                                2e-6f * std::max(1.f, std::abs(dec[k])));
                    EXPECT_NEAR(dec[k], x[k], 1e-5f * std::max(1.f, std::abs(x[k])));
                }
            }
        }
    });
}

TEST(SimdDecoder, SampleEncodedIsMeanPlusScaledNoise) {
    Decoder d = random_decoder("EventGen", 2);
    SimdDecoder s(d);
    Rng rng(9);
    for (int k = 0; k < 200; ++k) {
        std::vector<float> x(d.input_width), eps(6), mean(6), logvar(6), u(6);
        for (float& v : x) v = 4.f * rng.uniform() - 2.f;
        for (float& v : eps) v = 4.f * rng.uniform() - 2.f;
        evaluate_reference(d, x.data(), mean.data(), logvar.data());
        s.sample_encoded(x.data(), eps.data(), u.data());
        for (int i = 0; i < 6; ++i) {
            double want = mean[i] + std::exp(0.5 * logvar[i]) * eps[i];
            EXPECT_NEAR(u[i], want, 1e-5 * std::max(1.0, std::abs(want)));
        }
    }
}

// Softplus against PyTorch's definition in double precision: 1e-5 relative wherever the
// result is a normal float, and a tiny absolute error where it underflows to subnormals.
TEST(SimdDecoder, SoftplusMatchesTorchDefinition) {
    for_each_target([] {
        std::vector<float> x;
        for (float v = -110.f; v <= 110.f; v += 0.0137f) x.push_back(v);
        for (float v : {-0.f, 0.f, 19.999998f, 20.f, 20.000002f, 1e6f, -1e6f, 88.f, 89.f})
            x.push_back(v);
        std::vector<float> y(x.size());
        softplus_simd(x.data(), y.data(), x.size());
        double worst = 0;
        for (size_t i = 0; i < x.size(); ++i) {
            double want = x[i] > 20.f ? double(x[i]) : std::log1p(std::exp(double(x[i])));
            if (want > 1.2e-38) {
                worst = std::max(worst, rel_err(y[i], want));
                EXPECT_LT(rel_err(y[i], want), 1e-5) << "x = " << x[i];
                EXPECT_LT(rel_err(y[i], softplus(x[i])), 1e-5) << "x = " << x[i];
            } else {
                EXPECT_LE(std::abs(y[i] - want), 2e-38) << "x = " << x[i];
            }
        }
        std::ostringstream os;
        os << std::setprecision(2) << worst;
        RecordProperty(std::string(simd_target_name()) + "_softplus_max_rel_err",
                       os.str());
    });
}

TEST(SimdDecoder, NormalsMatchScalarBoxMuller) {
    for_each_target([] {
        for (int n : {1, 2, 3, 8, 11, 12, 16, 17, 40, 200}) {
            Rng a(3, uint64_t(n)), b(3, uint64_t(n));
            std::vector<float> za(n), zb(n);
            sample_normals(a, za.data(), n, DecoderImpl::Scalar);
            sample_normals(b, zb.data(), n, DecoderImpl::Simd);
            for (int i = 0; i < n; ++i)
                EXPECT_NEAR(za[i], zb[i], 2e-6 * std::max(1.f, std::abs(za[i])))
                    << n << " " << i;
            // Both consumed the same uniforms.
            EXPECT_EQ(a.next_u32(), b.next_u32()) << n;
        }
    });
}

TEST(SimdDecoder, NormalsAreStandardNormal) {
    Rng rng(17);
    const int n = 200000;
    std::vector<float> z(n);
    sample_normals(rng, z.data(), n, DecoderImpl::Simd);
    double m1 = 0, m2 = 0, m4 = 0, within1 = 0;
    for (float v : z) {
        m1 += v;
        m2 += double(v) * v;
        m4 += double(v) * v * v * v;
        within1 += std::abs(v) < 1.f;
    }
    m1 /= n;
    m2 /= n;
    m4 /= n;
    within1 /= n;
    EXPECT_NEAR(m1, 0.0, 5 * std::sqrt(1.0 / n));
    EXPECT_NEAR(m2, 1.0, 5 * std::sqrt(2.0 / n));
    EXPECT_NEAR(m4, 3.0, 5 * std::sqrt(96.0 / n));
    EXPECT_NEAR(within1, 0.682689492, 5 * std::sqrt(0.2166 / n));
}

}  // namespace
}  // namespace sss

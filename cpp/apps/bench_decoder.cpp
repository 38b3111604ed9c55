// sssphere-bench-decoder: what a learned sphere step costs next to one path-traced
// scattering event (bench/README.md: a step of LengthGen + PathGen should cost <= 3 PT
// events). Single thread, float, best of several runs; writes JSON (bench/README.md).
//
//   sssphere-bench-decoder [--models DIR] [-o bench/results/decoder_cost.json] [--quick]
//                          [--target SSE4|AVX2|AVX3]   (pin the SIMD target; default:
//                          best)
//
// Without --models it times random-weight decoders of paper Table 1's shapes (the cost
// does not depend on the weights, only N's distribution does, which the sigma values
// below make irrelevant: exp(-10) of the steps are N = 1).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/check.h"
#include "core/rng.h"
#include "core/vec.h"
#include "nn/random_models.h"
#include "nn/scattering_model.h"
#include "shared/hg.h"
#include "shared/sampling.h"

namespace {

using namespace sss;
using Clock = std::chrono::steady_clock;

volatile float g_sink;

// ns per call of f(i), i = 0 .. iters-1: the best of `trials` runs.
double ns_per_call(size_t iters, int trials, const std::function<void(size_t)>& f) {
    double best = 1e30;
    for (int t = 0; t < trials; ++t) {
        auto t0 = Clock::now();
        for (size_t i = 0; i < iters; ++i) f(i);
        double ns = std::chrono::duration<double, std::nano>(Clock::now() - t0).count() /
                    double(iters);
        best = std::min(best, ns);
    }
    return best;
}

// ns per step of sample_group on `count` steps (the SIMD decoder), iters / count calls,
// the best of `trials` runs.
double group_ns(const ScatteringModel& model, int count, const float* sigma,
                const float* g, const float* phi, Rng* rng, bool event, size_t iters,
                int trials) {
    SphereStep out[ScatteringModel::kMaxGroup];
    return ns_per_call(iters / size_t(count), trials,
                       [&](size_t) {
                           model.sample_group(count, sigma, g, phi, rng, event,
                                              DecoderImpl::Simd, out);
                           g_sink = out[0].cos_theta;
                       }) /
           count;
}

std::string cpu_model() {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
    return "unknown";
}

std::string json_string(const std::string& s) {
    std::string o = "\"";
    for (char c : s)
        o += c == '"' || c == '\\' ? std::string("\\") + c : std::string(1, c);
    return o + "\"";
}

}  // namespace

int main(int argc, char** argv) {
    std::string models, out_path = "bench/results/decoder_cost.json";
    std::string
        target;  // pin a SIMD target (SSE4, AVX2, AVX3, ...); default: the best here
    bool quick = false;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--models" && i + 1 < argc)
            models = argv[++i];
        else if (a == "-o" && i + 1 < argc)
            out_path = argv[++i];
        else if (a == "--quick")
            quick = true;
        else if (a == "--target" && i + 1 < argc)
            target = argv[++i];
        else {
            std::cerr << "usage: sssphere-bench-decoder [--models DIR] [-o OUT.json] "
                         "[--quick] [--target ISA]\n";
            return 2;
        }
    }
    try {
        if (!target.empty()) simd_use_target(target);
        ScatteringModel model = models.empty()
                                    ? ScatteringModel(random_decoder("LengthGen", 1),
                                                      random_decoder("PathGen", 1),
                                                      random_decoder("EventGen", 1),
                                                      "random Table-1 decoders")
                                    : ScatteringModel::load(models);
        // Many short runs, keep the best: on a shared machine the minimum is the cost.
        const size_t iters = quick ? 20000 : 100000;
        const int trials = quick ? 5 : 25;
        std::ostringstream js;
        js << "{\n  \"machine\": {\"cpu\": " << json_string(cpu_model())
           << ", \"hardware_threads\": " << std::thread::hardware_concurrency()
           << ", \"simd_target\": " << json_string(simd_target_name())
           << ", \"threads_used\": 1},\n";
        js << "  \"models\": " << json_string(model.where())
           << ",\n  \"iterations\": " << iters << ", \"trials\": " << trials
           << ", \"statistic\": \"best of trials, ns per call\",\n";

        // One PT scattering event: free flight, move, HG direction (with the frame
        // rotation). Timed again between the sections below and the best kept: on a
        // shared machine the load changes during the run, and the ratios should compare
        // quiet moments.
        Rng pt_rng(1);
        Vec3 pt_p(0.f), pt_d(0.f, 0.f, 1.f);
        double pt_ns = 1e30;
        auto time_pt = [&] {
            const float sigma_t = 10.f, g = 0.3f;
            pt_ns = std::min(pt_ns, ns_per_call(4 * iters, trials, [&](size_t) {
                                 float t = sample_exponential(pt_rng.uniform(), sigma_t);
                                 pt_p += pt_d * t;
                                 float u1 = pt_rng.uniform(), u2 = pt_rng.uniform();
                                 pt_d = hg_sample(pt_d, g, u1, u2);
                             }));
            g_sink = pt_p.x + pt_d.y;
        };
        time_pt();
        std::printf("PT scattering event: %.1f ns\n", pt_ns);

        // Decoder evaluations on 1024 random inputs in turn; the SIMD decoder also with 8
        // and 16 inputs per call (ns per input).
        js << "  \"decoder_ns_per_input\": {";
        const char* names[3] = {"LengthGen", "PathGen", "EventGen"};
        for (int k = 0; k < 3; ++k) {
            const Decoder& d = model.decoder(names[k]);
            const SimdDecoder& s = model.simd_decoder(names[k]);
            std::vector<float> x(1024 * size_t(d.input_width));
            Rng rng(2, k);
            for (float& v : x) v = 4.f * rng.uniform() - 2.f;
            float mean[16 * 64], logvar[16 * 64];
            double scalar = ns_per_call(iters / 4, trials, [&](size_t i) {
                evaluate_reference(d, &x[(i & 1023) * d.input_width], mean, logvar);
                g_sink = mean[0];
            });
            double simd[3];
            const int counts[3] = {1, 8, 16};
            for (int c = 0; c < 3; ++c) {
                const int n = counts[c];
                simd[c] = ns_per_call(iters / n, trials,
                                      [&](size_t i) {
                                          s.evaluate(&x[((i * n) & 1023) * d.input_width],
                                                     mean, logvar, n);
                                          g_sink = mean[0];
                                      }) /
                          n;
            }
            js << (k ? ", " : "") << "\n    \"" << names[k]
               << "\": {\"scalar\": " << scalar << ", \"simd\": " << simd[0]
               << ", \"simd_8_per_call\": " << simd[1]
               << ", \"simd_16_per_call\": " << simd[2] << "}";
            std::printf(
                "%-9s  scalar %6.1f ns   simd %6.1f ns   (8 per call %5.1f, 16 per call "
                "%5.1f ns each)\n",
                names[k], scalar, simd[0], simd[1], simd[2]);
        }
        js << "\n  },\n";

        // Gaussian draws of one step (LengthGen + PathGen: 2 + 1 + 5 + 3 = 11), RNG
        // included.
        {
            const int n =
                model.length_gen().latent_dim + 1 + model.path_gen().latent_dim + 3;
            float z[64];
            Rng rng(3);
            double scalar = ns_per_call(iters / 2, trials, [&](size_t) {
                sample_normals(rng, z, n, DecoderImpl::Scalar);
                g_sink = z[0];
            });
            double simd = ns_per_call(iters / 2, trials, [&](size_t) {
                sample_normals(rng, z, n, DecoderImpl::Simd);
                g_sink = z[0];
            });
            js << "  \"normals_ns\": {\"count\": " << n << ", \"scalar\": " << scalar
               << ", \"simd\": " << simd << "},\n";
            std::printf("%d normals  scalar %6.1f ns   simd %6.1f ns\n", n, scalar, simd);
        }

        time_pt();
        // Whole steps through the public API (input checks included), at sigma where N >=
        // 2 almost always (the N = 1 shortcut costs ~ a PT event and is timed
        // separately).
        js << "  \"step_ns\": {";
        const float g = 0.3f, phi = 0.9f;
        struct Case {
            const char* name;
            float sigma;
            bool event;
        } cases[] = {{"N_and_path", 10.f, false},
                     {"N_path_event", 10.f, true},
                     {"N_and_path_sigma_0.001", 0.001f, false},
                     {"N_and_path_sigma_100", 100.f, false}};
        bool first = true;
        double single_step_ns = 0, single_step_event_ns = 0, group16_ns = 0,
               group16_event_ns = 0, batch_ns = 0;
        for (const Case& c : cases) {
            double ns[2];
            for (int impl = 0; impl < 2; ++impl) {
                DecoderImpl which = impl ? DecoderImpl::Simd : DecoderImpl::Scalar;
                Rng rng(4);
                ns[impl] = ns_per_call(impl ? iters / 2 : iters / 8, trials, [&](size_t) {
                    SphereStep s = model.sample(c.sigma, g, phi, rng, c.event, which);
                    g_sink = s.cos_theta;
                });
            }
            js << (first ? "" : ",") << "\n    \"" << c.name
               << "\": {\"sigma\": " << c.sigma << ", \"scalar\": " << ns[0]
               << ", \"simd\": " << ns[1] << "}";
            first = false;
            if (c.sigma == 10.f && !c.event) single_step_ns = ns[1];
            if (c.sigma == 10.f && c.event) single_step_event_ns = ns[1];
            std::printf("step %-22s sigma %5.1f  scalar %6.1f ns   simd %6.1f ns\n",
                        c.name, c.sigma, ns[0], ns[1]);
        }
        js << "\n  },\n";

        // Several steps per call (sample_group, as a renderer advancing several paths
        // would call it) and the batch form on one thread (groups of kBatchGroup, outputs
        // stored).
        {
            js << "  \"group_N_and_path_ns_per_step\": {\"sigma\": 10";
            float sigma[16], gg[16], ph[16];
            std::fill(sigma, sigma + 16, 10.f);
            std::fill(gg, gg + 16, g);
            std::fill(ph, ph + 16, phi);
            Rng rng[16];
            for (int k = 0; k < 16; ++k) rng[k] = Rng(6, k);
            for (int K : {1, 2, 4, 8, 16}) {
                double ns =
                    group_ns(model, K, sigma, gg, ph, rng, false, iters / 2, trials);
                js << ", \"" << K << "\": " << ns;
                if (K == 16) group16_ns = ns;
                std::printf("group of %2d, N+path: %6.1f ns per step\n", K, ns);
            }
            js << "},\n";
            group16_event_ns =
                group_ns(model, 16, sigma, gg, ph, rng, true, iters, trials);
            js << "  \"group_16_N_path_event_ns_per_step\": " << group16_event_ns
               << ",\n";
            std::printf("group of 16, N+path+event: %6.1f ns per step\n",
                        group16_event_ns);

            const size_t n = quick ? 8000 : 40000;
            std::vector<float> bs(n, 10.f), bg(n, g), bp(n, phi);
            std::vector<SphereStep> bout(n);
            double ns[2];
            for (int impl = 0; impl < 2; ++impl) {
                DecoderImpl which = impl ? DecoderImpl::Simd : DecoderImpl::Scalar;
                ns[impl] =
                    ns_per_call(1, trials,
                                [&](size_t) {
                                    model.sample_batch(bs.data(), bg.data(), bp.data(),
                                                       impl ? n : n / 8, 5, 1, false,
                                                       which, bout.data());
                                }) /
                    double(impl ? n : n / 8);
            }
            js << "  \"batch_N_and_path_ns_per_sample\": {\"sigma\": 10, \"group\": "
               << ScatteringModel::kBatchGroup << ", \"scalar\": " << ns[0]
               << ", \"simd\": " << ns[1] << "},\n";
            batch_ns = ns[1];
            std::printf(
                "batch N+path per sample (1 thread): scalar %6.1f ns   simd %6.1f ns\n",
                ns[0], ns[1]);
        }
        // The forward-memory tilt (models with tilt.json): groups of K sphere steps with
        // and without it, at sigma 30 and g 0.9, where the shipped table refuses 8 % of
        // the draws (docs/sphere-tracing.md, "The forward-memory tilt").
        if (!model.tilt().empty()) {
            const StepTilt tilt = model.tilt();
            constexpr int kMax = ScatteringModel::kMaxGroup;
            float sigma[kMax], gg[kMax], ph[kMax];
            std::fill(sigma, sigma + kMax, 30.f);
            std::fill(gg, gg + kMax, 0.9f);
            std::fill(ph, ph + kMax, phi);
            Rng rng[kMax];
            for (int k = 0; k < kMax; ++k) rng[k] = Rng(7, k);
            js << "  \"tilt_group_ns_per_step\": {\"sigma\": 30, \"g\": 0.9";
            for (int K : {1, 4, 16, 64}) {
                double ns[2];
                for (int t = 0; t < 2; ++t) {
                    model.set_tilt(t ? tilt : StepTilt());
                    ns[t] =
                        group_ns(model, K, sigma, gg, ph, rng, false, iters / 2, trials);
                }
                js << ", \"" << K << "\": {\"untilted\": " << ns[0]
                   << ", \"tilted\": " << ns[1] << "}";
                std::printf(
                    "group of %2d, N+path: %6.1f ns per step, %6.1f with the tilt\n", K,
                    ns[0], ns[1]);
            }
            js << "},\n";
            model.set_tilt(tilt);
        }
        time_pt();
        js << "  \"pt_event_ns\": " << pt_ns << ",\n";
        js << "  \"in_pt_events\": {\"single_step_N_and_path\": "
           << single_step_ns / pt_ns
           << ", \"single_step_N_path_event\": " << single_step_event_ns / pt_ns
           << ", \"group_16_N_and_path\": " << group16_ns / pt_ns
           << ", \"group_16_N_path_event\": " << group16_event_ns / pt_ns
           << ", \"batch_N_and_path\": " << batch_ns / pt_ns << "}\n}\n";
        std::printf("PT scattering event (best over the run): %.1f ns\n", pt_ns);
        std::printf(
            "in PT events: single step N+path %.2f, group of 16 (as rendered) N+path "
            "%.2f, N+path+event "
            "%.2f\n",
            single_step_ns / pt_ns, group16_ns / pt_ns, group16_event_ns / pt_ns);

        std::ofstream out(out_path);
        if (!out) fail(out_path, ": cannot write");
        out << js.str();
        std::printf("wrote %s\n", out_path.c_str());
    } catch (const Error& e) {
        std::cerr << "sssphere-bench-decoder: " << e.what() << "\n";
        return 1;
    }
    return 0;
}

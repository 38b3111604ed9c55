// sssphere-bench-decoder: what a learned sphere step costs next to one path-traced
// scattering event (DESIGN §6, issue 4: a step of LengthGen + PathGen should cost <= 3 PT
// events). Single thread, float, best of several runs; writes JSON (bench/README.md).
//
//   sssphere-bench-decoder [--models DIR] [-o bench/results/decoder_cost.json] [--quick]
//
// Without --models it times random-weight decoders of paper Table 1's shapes (the cost does
// not depend on the weights, only N's distribution does, which the sigma values below make
// irrelevant: exp(-10) of the steps are N = 1).
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
#include "nn/scattering_model.h"
#include "shared/hg.h"
#include "shared/sampling.h"
#include "testing/random_models.h"

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
        double ns = std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / double(iters);
        best = std::min(best, ns);
    }
    return best;
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
    for (char c : s) o += c == '"' || c == '\\' ? std::string("\\") + c : std::string(1, c);
    return o + "\"";
}

}  // namespace

int main(int argc, char** argv) {
    std::string models, out_path = "bench/results/decoder_cost.json";
    bool quick = false;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--models" && i + 1 < argc) models = argv[++i];
        else if (a == "-o" && i + 1 < argc) out_path = argv[++i];
        else if (a == "--quick") quick = true;
        else {
            std::cerr << "usage: sssphere-bench-decoder [--models DIR] [-o OUT.json] [--quick]\n";
            return 2;
        }
    }
    try {
        ScatteringModel model =
            models.empty() ? ScatteringModel(test::random_decoder("LengthGen", 1), test::random_decoder("PathGen", 1),
                                             test::random_decoder("EventGen", 1), "random Table-1 decoders")
                           : ScatteringModel::load(models);
        const size_t iters = quick ? 100000 : 1000000;
        const int trials = quick ? 3 : 7;
        std::ostringstream js;
        js << "{\n  \"machine\": {\"cpu\": " << json_string(cpu_model())
           << ", \"hardware_threads\": " << std::thread::hardware_concurrency()
           << ", \"simd_target\": " << json_string(simd_target_name()) << ", \"threads_used\": 1},\n";
        js << "  \"models\": " << json_string(model.where()) << ",\n  \"iterations\": " << iters
           << ", \"trials\": " << trials << ", \"statistic\": \"best of trials, ns per call\",\n";

        // One PT scattering event: free flight, move, HG direction (with the frame rotation).
        double pt_ns;
        {
            Rng rng(1);
            Vec3 p(0.f), d(0.f, 0.f, 1.f);
            const float sigma_t = 10.f, g = 0.3f;
            pt_ns = ns_per_call(iters, trials, [&](size_t) {
                float t = sample_exponential(rng.uniform(), sigma_t);
                p += d * t;
                float u1 = rng.uniform(), u2 = rng.uniform();
                d = hg_sample(d, g, u1, u2);
            });
            g_sink = p.x + d.y;
        }
        js << "  \"pt_event_ns\": " << pt_ns << ",\n";
        std::printf("PT scattering event: %.1f ns\n", pt_ns);

        // Decoder evaluations on 1024 random inputs in turn.
        js << "  \"decoder_ns\": {";
        const char* names[3] = {"LengthGen", "PathGen", "EventGen"};
        for (int k = 0; k < 3; ++k) {
            const Decoder& d = model.decoder(names[k]);
            const SimdDecoder& s = model.simd_decoder(names[k]);
            std::vector<float> x(1024 * size_t(d.input_width));
            Rng rng(2, k);
            for (float& v : x) v = 4.f * rng.uniform() - 2.f;
            float mean[64], logvar[64];
            double scalar = ns_per_call(iters, trials, [&](size_t i) {
                evaluate_reference(d, &x[(i & 1023) * d.input_width], mean, logvar);
                g_sink = mean[0];
            });
            double simd = ns_per_call(iters, trials, [&](size_t i) {
                s.evaluate(&x[(i & 1023) * d.input_width], mean, logvar);
                g_sink = mean[0];
            });
            js << (k ? ", " : "") << "\n    \"" << names[k] << "\": {\"scalar\": " << scalar << ", \"simd\": " << simd
               << "}";
            std::printf("%-9s  scalar %6.1f ns   simd %6.1f ns\n", names[k], scalar, simd);
        }
        js << "\n  },\n";

        // Gaussian draws of one step (LengthGen + PathGen: 2 + 1 + 5 + 3 = 11), RNG included.
        {
            const int n = model.length_gen().latent_dim + 1 + model.path_gen().latent_dim + 3;
            float z[64];
            Rng rng(3);
            double scalar = ns_per_call(iters, trials, [&](size_t) {
                sample_normals(rng, z, n, DecoderImpl::Scalar);
                g_sink = z[0];
            });
            double simd = ns_per_call(iters, trials, [&](size_t) {
                sample_normals(rng, z, n, DecoderImpl::Simd);
                g_sink = z[0];
            });
            js << "  \"normals_ns\": {\"count\": " << n << ", \"scalar\": " << scalar << ", \"simd\": " << simd
               << "},\n";
            std::printf("%d normals  scalar %6.1f ns   simd %6.1f ns\n", n, scalar, simd);
        }

        // Whole steps through the public API (input checks included), at sigma where N >= 2
        // almost always (the N = 1 shortcut costs ~ a PT event and is timed separately).
        js << "  \"step_ns\": {";
        const float g = 0.3f, phi = 0.9f;
        struct Case {
            const char* name;
            float sigma;
            bool event;
        } cases[] = {{"N_and_path", 10.f, false}, {"N_path_event", 10.f, true}, {"N_and_path_sigma_0.1", 0.1f, false},
                     {"N_and_path_sigma_100", 100.f, false}};
        bool first = true;
        for (const Case& c : cases) {
            double ns[2];
            for (int impl = 0; impl < 2; ++impl) {
                DecoderImpl which = impl ? DecoderImpl::Simd : DecoderImpl::Scalar;
                Rng rng(4);
                ns[impl] = ns_per_call(iters / 2, trials, [&](size_t) {
                    SphereStep s = model.sample(c.sigma, g, phi, rng, c.event, which);
                    g_sink = s.cos_theta;
                });
            }
            js << (first ? "" : ",") << "\n    \"" << c.name << "\": {\"sigma\": " << c.sigma << ", \"scalar\": " << ns[0]
               << ", \"simd\": " << ns[1] << ", \"simd_in_pt_events\": " << ns[1] / pt_ns << "}";
            first = false;
            std::printf("step %-22s sigma %5.1f  scalar %6.1f ns   simd %6.1f ns  = %.2f PT events\n", c.name,
                        c.sigma, ns[0], ns[1], ns[1] / pt_ns);
        }
        js << "\n  },\n";

        // The batch form on one thread (Rng(seed, i) per sample, outputs stored).
        {
            const size_t n = quick ? 20000 : 200000;
            std::vector<float> sigma(n, 10.f), gg(n, g), ph(n, phi);
            std::vector<SphereStep> out(n);
            double ns[2];
            for (int impl = 0; impl < 2; ++impl) {
                DecoderImpl which = impl ? DecoderImpl::Simd : DecoderImpl::Scalar;
                ns[impl] = ns_per_call(1, trials, [&](size_t) {
                               model.sample_batch(sigma.data(), gg.data(), ph.data(), n, 5, 1, false, which, out.data());
                           }) /
                           double(n);
            }
            js << "  \"batch_N_and_path_ns_per_sample\": {\"sigma\": 10, \"scalar\": " << ns[0] << ", \"simd\": " << ns[1]
               << "}\n";
            std::printf("batch N+path per sample: scalar %6.1f ns   simd %6.1f ns\n", ns[0], ns[1]);
        }
        js << "}\n";

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

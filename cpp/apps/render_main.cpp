// sssphere-render: the C++ command-line renderer. Same scene loader and renderer as the
// Python package; Ctrl-C stops early and writes the image rendered so far.
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>

#include "core/check.h"
#include "io/image_io.h"
#include "render/renderer.h"
#include "render/scene.h"

namespace {

volatile std::sig_atomic_t g_interrupted = 0;
void on_sigint(int) { g_interrupted = 1; }

void usage() {
    std::cerr
        << "usage: sssphere-render SCENE.json -o OUT.(exr|png) [--spp N] [--seed N] "
           "[--threads N] [--integrator pt|st] [--sphere-threshold TAU] [--models DIR] "
           "[--step-nee hits|event] [--quiet] [--version]\n"
           "  st: a collision takes a sphere step where sigma_t * r >= TAU (default: the "
           "scene's\n"
           "  render.sphere_threshold, else "
        << sss::kDefaultSphereThreshold
        << "; inf: never); DIR holds lengthgen.json, pathgen.json,\n"
           "  eventgen.json (default: the scene's render.models, else the source tree's "
           "models/)\n"
           "  --step-nee: the direct light of a sphere step's events: 'hits' (default: "
           "from\n"
           "  its exit flight; EventGen only for point and directional lights) or "
           "'event'\n"
           "  (EventGen's representative event connects to every kind of light)\n";
}

float parse_threshold(const char* text) {
    char* end = nullptr;
    float v = std::strtof(text, &end);
    if (!text[0] || *end || !(v >= 0.f))
        sss::fail(
            "--sphere-threshold: expected a number >= 0 (inf: no sphere steps), got '",
            text, "'");
    return v;
}

long parse_int(const char* flag, const char* text) {
    char* end = nullptr;
    long v = std::strtol(text, &end, 10);
    if (!text[0] || *end) sss::fail(flag, ": expected an integer, got '", text, "'");
    return v;
}

// The shipped decoders when neither --models nor the scene names any: those installed
// with the Python package beside this program (a wheel puts the program in <env>/bin and
// the models in <env>/lib/pythonX.Y/site-packages/sssphere/models), else those of the
// source tree it was built from; empty if neither exists.
std::string shipped_models() {
    namespace fs = std::filesystem;
    std::error_code ec;
#ifdef SSSPHERE_INSTALLED_MODELS
    fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        fs::path dir = exe.parent_path() / SSSPHERE_INSTALLED_MODELS;
        if (fs::is_regular_file(dir / "lengthgen.json", ec))
            return dir.lexically_normal();
    }
#endif
#ifdef SSSPHERE_SOURCE_MODELS
    if (fs::is_directory(SSSPHERE_SOURCE_MODELS, ec)) return SSSPHERE_SOURCE_MODELS;
#endif
    return {};
}

}  // namespace

int main(int argc, char** argv) {
    std::string scene_path, out_path, integrator, models;
    float threshold = -1.f;  // < 0: the scene's
    long spp = -1, seed = -1, threads = 0;
    bool quiet = false;
    sss::StepNee step_nee = sss::StepNee::Hits;
    try {
        for (int i = 1; i < argc; ++i) {
            std::string a = argv[i];
            auto value = [&]() -> const char* {
                if (i + 1 >= argc) sss::fail(a, ": missing value");
                return argv[++i];
            };
            if (a == "-o" || a == "--output")
                out_path = value();
            else if (a == "--spp")
                spp = parse_int("--spp", value());
            else if (a == "--seed")
                seed = parse_int("--seed", value());
            else if (a == "--threads")
                threads = parse_int("--threads", value());
            else if (a == "--integrator")
                integrator = value();
            else if (a == "--sphere-threshold")
                threshold = parse_threshold(value());
            else if (a == "--models")
                models = value();
            else if (a == "--step-nee")
                step_nee = sss::parse_step_nee(value(), "--step-nee");
            else if (a == "--quiet")
                quiet = true;
            else if (a == "--version") {
                std::cout << "sssphere-render " << SSSPHERE_VERSION << "\n";
                return 0;
            } else if (a == "-h" || a == "--help") {
                usage();
                return 0;
            } else if (!a.empty() && a[0] == '-')
                sss::fail("unknown option '", a, "'");
            else if (scene_path.empty())
                scene_path = a;
            else
                sss::fail("more than one scene given ('", scene_path, "', '", a, "')");
        }
        if (scene_path.empty() || out_path.empty()) {
            usage();
            return 2;
        }
        if (spp == 0 || spp < -1) sss::fail("--spp must be >= 1, got ", spp);
        if (threads < 0) sss::fail("--threads must be >= 0, got ", threads);

        sss::SceneDesc desc = sss::load_scene_file(scene_path);
        for (const std::string& w : desc.warnings)
            std::cerr << "sssphere-render: warning: " << w << "\n";
        if (!integrator.empty()) desc.render.integrator = integrator;
        sss::RenderOptions opt;
        opt.integrator = desc.render.integrator;
        opt.spp = spp > 0 ? int(spp) : desc.render.spp;
        opt.seed = seed >= 0 ? uint64_t(seed) : desc.render.seed;
        opt.threads = int(threads);
        opt.max_bounces = desc.render.max_bounces;
        opt.sphere_threshold =
            threshold >= 0.f ? threshold : desc.render.sphere_threshold;
        opt.models = models.empty() ? desc.render.models : models;
        opt.step_nee = step_nee;
        if (opt.models.empty()) opt.models = shipped_models();
        sss::Scene scene(std::move(desc), opt.threads);

        std::signal(SIGINT, on_sigint);
        sss::RenderResult r = sss::render(scene, opt, [&](double f) {
            if (!quiet) {
                int filled = int(f * 40);
                std::fprintf(stderr, "\r[%-40s] %5.1f%%",
                             std::string(filled, '#').c_str(), 100 * f);
            }
            return !g_interrupted;
        });
        if (!quiet) std::fprintf(stderr, "\n");
        sss::write_image(out_path, r.image, r.width, r.height);
        double paths = double(r.total_paths);
        std::string steps;
        if (r.total_sphere_steps > 0) {
            char buf[96];
            std::snprintf(buf, sizeof buf, " + %.1f sphere steps (%.0f ns each)",
                          r.total_sphere_steps / paths,
                          1e9 * r.step_seconds / double(r.total_sphere_steps));
            steps = buf;
        }
        std::fprintf(stderr, "%s %s: %.2f s, %.1f scattering events%s per path\n",
                     r.cancelled ? "interrupted; wrote the partial image" : "wrote",
                     out_path.c_str(), r.seconds,
                     paths > 0 ? r.total_events / paths : 0.0, steps.c_str());
        return r.cancelled ? 130 : 0;
    } catch (const std::exception& e) {
        std::cerr << "sssphere-render: error: " << e.what() << "\n";
        return 1;
    }
}

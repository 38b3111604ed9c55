// sssphere-gpu-bench: renders baked scenes (python: sssphere._core.bake_gpu_scene; see
// bench/gpu_st_vs_pt.py) with "pt" and "st" on the Vulkan device and reports the times.
// Needs only Vulkan, so it runs on a GPU machine without the renderer's other libraries.
//
//   sssphere-gpu-bench --spp N [--batch B] [--lanes L] [--repeat R] [--out DIR]
//                      NAME=SCENE.bin[,OVERRIDE...] ...
//
// --batch: samples per pixel per dispatch (default: about 2^20 paths per dispatch, at
// most spp; the JSON gives the batch used).
// --lanes: invocations per dispatch, each rendering every lanes-th path (default: one per
// path; RenderOptions::gpu_lanes).
//
// An override changes every shape's medium or boundary before rendering, so one baked
// file (geometry, grids, decoders) serves a density sweep: sigma_t=X and albedo=X (all
// channels), threshold=X (the sphere threshold tau; inf: "st" takes no step),
// boundary=dielectric|index_matched, or nee=0|1 (light sampling in the shaders; the bake
// turns it on only for index-matched media, where it changes the estimator).
//
// --steps N: also times N sphere steps sampled alone (sample_steps.comp, sigma uniform in
// [6, 200], g = 0.9) with the first scene's decoders: the cost of one step without
// divergence.
//
// For each scene and integrator: one warm-up dispatch of 1 spp, then R renders of N spp;
// prints one JSON object per render (GPU time of the dispatches, wall time, events and
// steps per path), and with --out writes DIR/NAME_<integrator>.f32: the last render's
// mean image then the variance of that mean, float32, each (height, width, 3), row 0 at
// the top.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "core/check.h"
#include "gpu/gpu_renderer.h"
#include "render/boundaries/registry.h"

using namespace sss;

namespace {

// The boundary type an override "boundary=<name>" names, or null.
const BoundaryKind* boundary_named(const std::string& key, const std::string& name) {
    if (key != "boundary") return nullptr;
    for (const BoundaryKind& k : boundary_kinds())
        if (name == k.name) return &k;
    return nullptr;
}

std::string boundary_names() {
    std::string names;
    for (const BoundaryKind& k : boundary_kinds())
        names += std::string(names.empty() ? "" : "|") + k.name;
    return names;
}

// Gives shape s a boundary of type `kind` with its defaults.
void set_boundary(GpuShape& s, const BoundaryKind& kind) {
    const std::string source = "boundary override";
    BoundaryData b =
        kind.parse(json_fields::json::object(), json_fields::Field{source, ""});
    s.boundary[0] = float(kind.id);
    s.boundary[1] = b.x;
    s.boundary[2] = b.y;
}

}  // namespace

int main(int argc, char** argv) {
    int spp = 16, repeat = 1, batch = 0, lanes = 0;
    long step_count = 0;
    std::string out_dir;
    std::vector<std::pair<std::string, std::string>> scenes;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "sssphere-gpu-bench: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--spp") {
            spp = std::stoi(value());
        } else if (a == "--steps") {
            step_count = std::stol(value());
        } else if (a == "--batch") {
            batch = std::stoi(value());
        } else if (a == "--lanes") {
            lanes = std::stoi(value());
        } else if (a == "--repeat") {
            repeat = std::stoi(value());
        } else if (a == "--out") {
            out_dir = value();
        } else if (a.find('=') != std::string::npos && a[0] != '-') {
            scenes.emplace_back(a.substr(0, a.find('=')), a.substr(a.find('=') + 1));
        } else {
            std::fprintf(
                stderr,
                "usage: sssphere-gpu-bench --spp N [--batch B] [--lanes L] [--repeat R] "
                "[--out DIR] NAME=SCENE.bin ...\n");
            return 2;
        }
    }
    if (scenes.empty() || spp < 1 || repeat < 1) {
        std::fprintf(stderr, "sssphere-gpu-bench: no scenes, or spp / repeat < 1\n");
        return 2;
    }
    try {
        VulkanCompute vk;
        std::fprintf(stderr, "device: %s\n", vk.device_name().c_str());
        if (step_count > 0) {
            std::string file = scenes[0].second;
            file = file.substr(0, file.find(','));
            const GpuSceneData scene = load_gpu_scene(file);
            std::vector<float> sigma(static_cast<size_t>(step_count));
            std::vector<float> g(sigma.size(), 0.9f);
            for (size_t i = 0; i < sigma.size(); ++i)
                sigma[i] = 6.f + 194.f * float(i % 1024) / 1023.f;
            for (int k = 0; k < 3; ++k) {
                double t = 0.0;
                gpu_sample_steps(vk, scene.model, sigma.data(), g.data(), nullptr,
                                 sigma.size(), uint64_t(k), /*with_event=*/false, &t);
                std::printf(
                    "{\"steps\": %ld, \"device\": \"%s\", \"gpu_seconds\": %.6f, "
                    "\"ns_per_step\": %.4f}\n",
                    step_count, vk.device_name().c_str(), t,
                    1e9 * t / double(step_count));
            }
        }
        for (const auto& [name, path] : scenes) {
            std::string file = path, overrides;
            if (path.find(',') != std::string::npos) {
                file = path.substr(0, path.find(','));
                overrides = path.substr(path.find(',') + 1) + ",";
            }
            GpuSceneData scene = load_gpu_scene(file);
            for (size_t at = 0; at < overrides.size();) {
                const size_t end = overrides.find(',', at);
                const std::string kv = overrides.substr(at, end - at);
                at = end + 1;
                const std::string key = kv.substr(0, kv.find('='));
                const std::string val =
                    kv.find('=') == std::string::npos ? "" : kv.substr(kv.find('=') + 1);
                for (uint32_t i = 0; i < scene.header.counts[0]; ++i) {
                    GpuShape& s = scene.header.shapes[i];
                    const float smallest =
                        std::min({s.sigma_t[0], s.sigma_t[1], s.sigma_t[2]});
                    // A medium's plane certificates were built for balls of 6 mean free
                    // paths of its extinction then (GpuCutGrid::params.z).
                    if (key == "sigma_t" && scene.header.cut_grids[i].n[0] > 0 &&
                        std::stof(val) != smallest)
                        fail(file, ": override '", kv, "': the scene was baked with cut ",
                             "steps for sigma_t ", smallest,
                             "; bake it again for another");
                    if (key == "sigma_t")
                        s.sigma_t[0] = s.sigma_t[1] = s.sigma_t[2] = std::stof(val);
                    else if (key == "albedo")
                        s.albedo[0] = s.albedo[1] = s.albedo[2] = std::stof(val);
                    else if (key == "threshold")
                        scene.header.params[1] = std::stof(val);
                    else if (key == "nee" && (val == "0" || val == "1"))
                        scene.header.lighting[1] =
                            val == "1" && scene.header.lighting[0] > 0 ? 1u : 0u;
                    else if (const BoundaryKind* kind = boundary_named(key, val))
                        set_boundary(s, *kind);
                    else
                        fail("override '", kv, "' is not allowed (allowed: sigma_t=X, ",
                             "albedo=X, threshold=X, boundary=", boundary_names(),
                             " (with its defaults), nee=0|1)");
                }
            }
            GpuRenderer renderer(vk, scene);
            const bool has_st = !scene.model.empty();
            for (const char* integrator : {"pt", "st"}) {
                if (std::strcmp(integrator, "st") == 0 && !has_st) continue;
                RenderOptions opt;
                opt.integrator = integrator;
                opt.spp = 1;
                const RenderResult warm = renderer.render(opt);  // pipeline, caches
                opt.spp = spp;
                // Fixed dispatches, not the renderer's default ramp by time: a benchmark
                // times full ones.
                const int full = int(std::max<int64_t>(
                    1, (int64_t(1) << 20) / (int64_t(warm.width) * warm.height)));
                opt.gpu_batch = batch > 0 ? batch : std::min(full, spp);
                opt.gpu_lanes = lanes;
                RenderResult r;
                for (int k = 0; k < repeat; ++k) {
                    r = renderer.render(opt);
                    std::printf(
                        "{\"scene\": \"%s\", \"integrator\": \"%s\", \"device\": \"%s\", "
                        "\"width\": %d, \"height\": %d, \"spp\": %d, \"repeat\": %d, "
                        "\"batch\": %d, \"lanes\": %d, \"gpu_seconds\": %.6f, "
                        "\"seconds\": %.6f, "
                        "\"events_per_path\": "
                        "%.4f, \"steps_per_path\": %.4f}\n",
                        name.c_str(), integrator, r.device.c_str(), r.width, r.height,
                        spp, k, opt.gpu_batch, lanes, r.gpu_seconds, r.seconds,
                        double(r.total_events) / double(r.total_paths),
                        double(r.total_sphere_steps) / double(r.total_paths));
                    std::fflush(stdout);
                }
                if (!out_dir.empty()) {
                    std::string file = out_dir + "/" + name + "_" + integrator + ".f32";
                    std::ofstream f(file, std::ios::binary);
                    f.write(reinterpret_cast<const char*>(r.image.data()),
                            std::streamsize(r.image.size() * sizeof(float)));
                    f.write(reinterpret_cast<const char*>(r.variance.data()),
                            std::streamsize(r.variance.size() * sizeof(float)));
                    if (!f) fail(file, ": cannot be written");
                }
            }
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sssphere-gpu-bench: %s\n", e.what());
        return 1;
    }
    return 0;
}

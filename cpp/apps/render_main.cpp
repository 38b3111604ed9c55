// sssphere-render: the C++ command-line renderer, the twin of `sssphere render`: the same
// scene loader, the same options (one table, render/options.h, which both command lines
// are built from) and the same renderers. Ctrl-C stops early and writes the image
// rendered so far.
#include <fcntl.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <map>
#include <optional>
#include <string>

#include "core/check.h"
#include "gpu/backends.h"
#include "io/image_io.h"
#include "render/aovs.h"
#include "render/options.h"
#include "render/renderer.h"
#include "render/scene.h"

namespace {

// Ctrl-C, SIGTERM (kill, batch schedulers) and SIGHUP (a closed terminal, a dropped ssh
// session) stop the render; the image so far is written and the exit status says which:
// 130, 143 or 129. After SIGHUP stdout and stderr go to /dev/null (the terminal is gone:
// writes to it fail).
// While the scene loads, the first signal stops the distance grids' build (the parts of
// the load before it run to their end) and the next one ends the process at once.
// g_signal is read by the grid build's threads too: an atomic (lock-free, so the handler
// may set it).
std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);
volatile std::sig_atomic_t g_loading = 0;
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};
void on_signal(int sig) {
    g_signal = sig;
    if (sig == SIGHUP) {  // open and dup2 are async-signal-safe
        const int devnull = open("/dev/null", O_WRONLY);
        if (devnull >= 0) {
            dup2(devnull, 1);
            dup2(devnull, 2);
            close(devnull);
        }
    }
    if (g_loading)
        for (int s : kStopSignals) std::signal(s, SIG_DFL);
}

// The shipped decoders when neither --models nor the scene names any: those installed
// with the Python package beside this program (a wheel puts the program in <env>/bin and
// the models in <env>/lib/pythonX.Y/site-packages/sssphere/models), else those of the
// source tree it was built from (a build tree, or an editable install, whose Python
// package uses them too: cpp/CMakeLists.txt); empty if neither exists.
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

std::string flag_of(const std::string& name) {
    std::string flag = name;
    for (char& c : flag)
        if (c == '_') c = '-';
    return flag;
}

}  // namespace

// The image and its AOVs as `sssphere render --aovs` writes them (RenderResult.layers,
// python/sssphere/rendering.py): one multilayer .exr, or OUT_NAME.exr files beside a
// .png.
// Beside a .png, AOV `name` goes to STEM_NAME.exr.
static std::string aov_file(const std::string& out_path, const std::string& name) {
    return std::filesystem::path(out_path).replace_extension().string() + "_" + name +
           ".exr";
}

// Returns the AOV files written beside a .png (none for an .exr).
static const char* const kOneSampleVariance =
    "variance: one sample per pixel gives no estimate of the variance: its layer is 0, "
    "which does not mean 'no noise' (render 2 or more samples per pixel)";

static std::vector<std::string> write_with_aovs(const std::string& out_path,
                                                const sss::Scene& scene,
                                                const sss::RenderOptions& opt,
                                                const sss::RenderResult& r) {
    const sss::FirstHitAovs a = sss::first_hit_aovs(
        scene, opt.seed, std::clamp(r.spp, 1, sss::kDefaultAovSamples), opt.threads);
    const std::vector<std::string> rgb{"R", "G", "B"}, xyz{"X", "Y", "Z"};
    std::vector<sss::ImageLayer> layers{{"variance", rgb, r.variance},
                                        {"events", {"Y"}, r.events}};
    if (r.total_sphere_steps > 0)
        layers.push_back({"sphere_steps", {"Y"}, r.sphere_steps});
    layers.push_back({"albedo", rgb, a.albedo});
    layers.push_back({"normal", xyz, a.normal});
    layers.push_back({"depth", {"Z"}, a.depth});
    std::string ext = std::filesystem::path(out_path).extension().string();
    for (char& c : ext) c = char(std::tolower((unsigned char)c));
    if (ext == ".exr") {
        layers.insert(layers.begin(), {"", rgb, r.image});
        sss::write_exr_layers(out_path, r.width, r.height, layers);
        return {};
    }
    sss::write_image(out_path, r.image, r.width, r.height);
    std::vector<std::string> written;
    for (sss::ImageLayer& l : layers) {  // channels named as in the .exr's layers
        written.push_back(aov_file(out_path, l.name));
        sss::write_exr_layers(written.back(), r.width, r.height,
                              {{"", l.channels, std::move(l.data)}});
    }
    return written;
}

int main(int argc, char** argv) {
    CLI::App app{
        "Render a scene file (docs/scene-format.md) to an image: .exr (linear) or "
        ".png (sRGB). The C++ twin of `sssphere render`.",
        "sssphere-render"};
    // An option given twice takes its last value, as `sssphere render` (argparse) does;
    // --set is repeatable (take_all below).
    app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    sss::install_image_reader();  // environment maps
    std::string scene_path, out_path;
    bool quiet = false, aovs = false;
    app.add_option("scene", scene_path, "scene file (JSON, docs/scene-format.md)")
        ->required();
    app.add_option("-o,--output", out_path, "output image (.exr linear, .png sRGB)")
        ->required();
    // The render options, from the one table; values are checked when resolved, with the
    // same messages as the Python API's.
    std::map<std::string, std::string> given;
    for (const sss::OptionSpec& spec : sss::render_option_specs()) {
        if (!spec.command_line) continue;
        const std::string name = spec.name;
        if (spec.kind == sss::OptionSpec::Kind::Flag)
            app.add_flag_callback(
                "--no-" + flag_of(name), [&given, name] { given[name] = "false"; },
                std::string("turn off ") + spec.help);
        else {
            CLI::Option* o =
                app.add_option_function<std::string>(
                       "--" + flag_of(name),
                       [&given, name](const std::string& v) { given[name] = v; },
                       spec.help)
                    ->type_name(spec.metavar);
            if (name == "models") o->default_str(shipped_models());  // said in --help
        }
    }
    app.add_flag(
        "--aovs", aovs,
        "also write the variance, scattering events per path, sphere steps (st), "
        "first-hit albedo, normal and depth: as layers of OUT for an .exr, as "
        "OUT_NAME.exr files beside a .png");
    std::vector<std::string> assignments;
    int width = 0, height = 0;
    app.add_option("--set", assignments,
                   "change a scene field before loading, e.g. --set "
                   "shapes[0].medium.sigma_t=1000 or --set 'camera.origin=[0, 1, 3]' "
                   "(VALUE is JSON, else a string; repeatable)")
        ->type_name("PATH=VALUE")
        ->expected(1)
        ->take_all()
        ->check(  // a PATH and an '=': else a usage error (status 2), not the scene's
            [](const std::string& text) -> std::string {
                const size_t eq = text.find('=');
                if (eq == std::string::npos ||
                    text.substr(0, eq).find_first_not_of(" \t") == std::string::npos)
                    return "expected PATH=VALUE, e.g. shapes[0].medium.sigma_t=1000, got "
                           "'" +
                           text + "'";
                return "";
            });
    // --width and --height: read as text and checked and converted by one base-10 parser,
    // with the Python command line's messages (CLI::Range said "Value 16.5 not in range 1
    // to 16384", and CLI11's own conversion reads "010" as octal).
    std::string width_text, height_text;
    auto pixels = [](const std::string& text, int* value) -> std::string {
        size_t end = 0;
        long long v = 0;
        try {
            v = std::stoll(text, &end, 10);
        } catch (const std::out_of_range&) {
            return "must be 1 to 16384, got " + text;
        } catch (const std::exception&) {
            end = 0;
        }
        if (end == 0 || end != text.size())
            return "expected an integer, got '" + text + "'";
        if (v < 1 || v > 16384) return "must be 1 to 16384, got " + std::to_string(v);
        if (value) *value = int(v);
        return "";
    };
    auto check_pixels = [pixels](const std::string& t) { return pixels(t, nullptr); };
    app.add_option("--width", width_text,
                   "image width (alone: the height follows the scene's aspect ratio)")
        ->type_name("INT")
        ->check(check_pixels);
    app.add_option("--height", height_text,
                   "image height (alone: the width follows the scene's aspect ratio)")
        ->type_name("INT")
        ->check(check_pixels);
    app.add_flag("--quiet", quiet, "no progress bar");
    app.set_version_flag("--version", std::string("sssphere-render ") + SSSPHERE_VERSION);
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {  // --help, --version
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "sssphere-render: error: " << e.what()
                  << "\n(sssphere-render --help lists the options)\n";
        return 2;
    }
    if (!width_text.empty()) pixels(width_text, &width);
    if (!height_text.empty()) pixels(height_text, &height);

    // Each option's value before the scene is read (their combinations after it, with the
    // scene's): a value out of range is a usage error, as --width 0 is
    sss::RenderOverrides overrides;
    try {
        for (const auto& [name, text] : given)
            sss::set_override_from_text(overrides, name, text);
    } catch (const sss::Error& e) {
        std::cerr << "sssphere-render: error: " << e.what()
                  << "\n(sssphere-render --help lists the options)\n";
        return 2;
    }

    try {
        sss::check_output_image(out_path);
        // A signal the process was started ignoring (a background job's SIGINT) stays so.
        bool ignored[std::size(kStopSignals)] = {};  // nohup's SIGHUP stays ignored
        auto install = [&ignored] {
            int k = 0;
            for (int sig : kStopSignals) {
                if (std::signal(sig, on_signal) == SIG_IGN) ignored[k] = true;
                if (ignored[k++]) std::signal(sig, SIG_IGN);
            }
        };
        g_loading = 1;
        install();
        auto interrupted = [] { return 128 + (g_signal ? int(g_signal) : SIGINT); };
        if (!quiet && isatty(2))  // the build can take seconds before the bar
            std::fprintf(stderr, "loading %s ...\n", scene_path.c_str());
        const auto t_load = std::chrono::steady_clock::now();
        sss::SceneDesc desc =
            sss::load_scene_file(scene_path, assignments, width, height);
        std::vector<std::string> inputs = desc.inputs, outputs{out_path};
        inputs.push_back(scene_path);
        std::string ext = std::filesystem::path(out_path).extension().string();
        for (char& c : ext) c = char(std::tolower((unsigned char)c));
        if (aovs && ext != ".exr")
            for (const char* name :
                 {"variance", "events", "sphere_steps", "albedo", "normal", "depth"})
                outputs.push_back(aov_file(out_path, name));
        for (const std::string& o : outputs) {
            sss::check_output_image(o);  // the AOV files' names too, before the render
            sss::check_output_is_not_an_input(o, inputs);
        }
        for (const std::string& w : desc.warnings)
            std::cerr << "sssphere-render: warning: " << w << "\n";
        const sss::RenderOptions opt = sss::resolve_render_options(
            desc.render, desc.source, overrides, shipped_models());
        // The distance grids' build stops at a signal; the rest of the load (reading and
        // checking the meshes, the BVH) finishes first.
        std::optional<sss::Scene> built;
        try {
            built.emplace(std::move(desc), opt.threads, [] { return g_signal != 0; });
        } catch (const sss::Cancelled&) {
        }
        const double load_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t_load)
                .count();
        g_loading = 0;
        install();  // again: a second signal during the load put back the defaults
        if (g_signal) {
            std::fprintf(stderr,
                         "interrupted while loading the scene: wrote nothing to %s\n",
                         out_path.c_str());
            return interrupted();
        }
        const sss::Scene& scene = *built;
        // Media "st" takes no steps in are said before the render, which may be long.
        const std::vector<std::string> said =
            opt.integrator == "st" ? sss::check_sphere_steps(scene, opt).warnings
                                   : std::vector<std::string>();
        for (const std::string& w : said)
            std::cerr << "sssphere-render: warning: " << w << "\n";
        sss::RenderResult r = sss::render_with_backend(scene, opt, [&](double f) {
            if (!quiet) {
                int filled = int(f * 40);
                std::fprintf(stderr, "\r[%-40s] %5.1f%%",
                             std::string(filled, '#').c_str(), 100 * f);
            }
            return g_signal == 0;
        });
        if (!quiet) std::fprintf(stderr, "\n");
        for (const std::string& w : r.warnings)
            if (std::find(said.begin(), said.end(), w) == said.end())
                std::cerr << "sssphere-render: warning: " << w << "\n";
        if (r.cancelled && r.spp == 0) {  // an all-black image would look like a render
            std::fprintf(
                stderr,
                "interrupted before the first pass finished: wrote nothing to %s\n",
                out_path.c_str());
            return interrupted();
        }
        std::vector<std::string> aov_files;
        if (aovs) {
            if (r.spp < 2)  // the same words as RenderResult.save (rendering.py)
                std::cerr << "sssphere-render: warning: " << kOneSampleVariance << "\n";
            aov_files = write_with_aovs(out_path, scene, opt, r);
        } else
            sss::write_image(out_path, r.image, r.width, r.height);
        // The summary line, word for word that of `sssphere render` (cli.py).
        const double paths = double(r.total_paths);
        char buf[256];
        std::string steps;
        if (r.total_sphere_steps > 0) {
            std::snprintf(buf, sizeof buf, " + %.1f sphere steps",
                          r.total_sphere_steps / paths);
            steps = buf;
            if (r.step_seconds > 0) {
                std::snprintf(buf, sizeof buf, " (%.0f ns each)",
                              1e9 * r.step_seconds / double(r.total_sphere_steps));
                steps += buf;
            }
        }
        std::string beside;
        if (!aov_files.empty())
            beside = " and " + std::to_string(aov_files.size()) +
                     " AOV files beside it (" +
                     std::filesystem::path(aov_files[0]).filename().string() + ", ...)";
        const std::string device = r.device.empty() ? "" : " on " + r.device + ";";
        std::snprintf(buf, sizeof buf,
                      " scene built in %.2fs, rendered in %.2fs; %.1f scattering events",
                      load_seconds, r.seconds, paths > 0 ? r.total_events / paths : 0.0);
        const std::string size = " (" + std::to_string(r.width) + "x" +
                                 std::to_string(r.height) + ", " + std::to_string(r.spp) +
                                 " spp;" + device;
        std::cerr << (r.cancelled ? "interrupted: wrote the partial image"
                      : g_signal  ? "interrupted once the render had finished: wrote"
                      : r.time_limit_reached ? "time limit reached: wrote"
                                             : "wrote")
                  << " " << out_path << beside << size << buf << steps << " per path)\n";
        return r.cancelled || g_signal ? interrupted() : 0;
    } catch (const std::exception& e) {
        std::cerr << "sssphere-render: error: " << e.what() << "\n";
        return 1;
    }
}

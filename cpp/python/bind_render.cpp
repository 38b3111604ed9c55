// Rendering for Python: the option table, the options resolved from keyword arguments
// (and from command-line text, for `sssphere render`), and a render on either backend.
// The options are render/options.h's: defaults, checks and messages live there once.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <string>

#include "core/check.h"
#include "gpu/backends.h"
#include "python/released_gil.h"
#include "python/render_progress.h"
#include "render/aovs.h"
#include "render/medium_presets.h"
#include "render/options.h"
#include "render/scene.h"
#include "shared/sphere_step.h"

namespace py = pybind11;
using namespace sss;

namespace {

using Kind = OptionSpec::Kind;

// Overrides from keyword arguments (None: not set). A value of the wrong type gets the
// message a value out of range would get, naming what is allowed.
RenderOverrides overrides_from(const py::dict& text, const py::kwargs& kwargs) {
    RenderOverrides o;
    for (const auto& [key, value] : text)
        set_override_from_text(o, py::str(key), py::str(value));
    for (const auto& [key, value] : kwargs) {
        const std::string name = py::str(key);
        const OptionSpec& spec = render_option_spec(name);
        if (value.is_none()) continue;
        const std::string shown = py::repr(value);
        switch (spec.kind) {
            case Kind::Integer: {
                bool ok = !is_bool(value) && PyIndex_Check(value.ptr());
                int64_t v = 0;
                if (ok) {
                    try {
                        v = py::int_(py::reinterpret_borrow<py::object>(value))
                                .cast<int64_t>();
                    } catch (const py::cast_error&) {
                        ok = false;
                    }
                }
                if (!ok) fail(name, " must be ", spec.allowed, ", got ", shown);
                set_override(o, name, v);
                break;
            }
            case Kind::Number:
                if (is_bool(value) ||
                    !(PyFloat_Check(value.ptr()) || PyIndex_Check(value.ptr())) ||
                    std::isnan(value.cast<double>()))
                    fail(name, " must be ", spec.allowed, ", got ", shown);
                set_override(o, name, value.cast<double>());
                break;
            case Kind::Text:
                try {
                    set_override(o, name,
                                 std::string(py::str(
                                     py::module_::import("os").attr("fspath")(value))));
                } catch (const py::error_already_set&) {
                    fail(name, " must be a path (str or os.PathLike), got ", shown);
                }
                break;
            case Kind::Choice:
                if (!py::isinstance<py::str>(value))
                    fail(name, " must be one of its names (a str), got ", shown);
                set_override(o, name, std::string(py::str(value)));
                break;
            case Kind::Flag:
                if (!is_bool(value)) fail(name, " must be True or False, got ", shown);
                set_override(o, name, value.cast<bool>());
                break;
        }
    }
    return o;
}

py::dict options_dict(const RenderOptions& r) {
    py::dict d;
    d["integrator"] = r.integrator;
    d["spp"] = r.spp;
    d["seed"] = r.seed;
    d["threads"] = r.threads;
    d["max_bounces"] = r.max_bounces;
    d["nee"] = r.nee;
    d["sphere_threshold"] = r.sphere_threshold;
    d["models"] = r.models;
    d["cut_models"] = r.cut_models;
    d["sphere_sampler"] = to_string(r.sphere_sampler);
    d["step_nee"] = to_string(r.step_nee);
    d["record_paths"] = r.record_paths;
    d["backend"] = to_string(r.backend);
    d["time_limit"] = r.time_limit;
    return d;
}

py::dict film_sums(const Film& film) {
    const py::ssize_t n = py::ssize_t(film.pixels());
    py::dict d;
    d["sum"] = py::array_t<double>({n, py::ssize_t(3)}, film.sums().data());
    d["sum_sq"] = py::array_t<double>({n, py::ssize_t(3)}, film.sums_of_squares().data());
    d["events"] = py::array_t<uint64_t>(n, film.event_counts().data());
    d["steps"] = py::array_t<uint64_t>(n, film.step_counts().data());
    return d;
}

}  // namespace

void bind_render(py::module_& m) {
    m.attr("DEFAULT_SPHERE_THRESHOLD") = kDefaultSphereThreshold;
    m.attr("DELTA_LIGHT_CLEARANCE") = kDeltaLightClearance;
    m.attr("SPECTRAL_SWITCH_RATIO") = kSpectralSwitchRatio;
    m.def(
        "render_option_specs",
        []() {
            py::list out;
            for (const OptionSpec& s : render_option_specs()) {
                static const char* kinds[] = {"integer", "number", "text", "choice",
                                              "flag"};
                py::dict d;
                d["name"] = s.name;
                d["kind"] = kinds[int(s.kind)];
                d["choices"] = s.choices;
                d["metavar"] = s.metavar;
                d["help"] = s.help;
                d["command_line"] = s.command_line;
                out.append(d);
            }
            return out;
        },
        "The render options, one dict each: name, kind, choices, metavar, help, "
        "command_line (render/options.h).");
    m.def(
        "resolve_render_options",
        [](const Scene& scene, const std::string& default_models, const py::dict& text,
           const py::kwargs& options) {
            return options_dict(
                resolve_render_options(scene.desc().render, scene.desc().source,
                                       overrides_from(text, options), default_models));
        },
        py::arg("scene"), py::arg("default_models") = "", py::arg("text") = py::dict(),
        "The options a render would use: defaults < the scene's render block < `text` "
        "(command-line strings) < keyword arguments.");
    m.def(
        "check_sphere_steps",
        [](const Scene& scene, const std::string& default_models, const py::dict& text,
           const py::kwargs& options) {
            const SphereStepCheck check = check_sphere_steps(
                scene,
                resolve_render_options(scene.desc().render, scene.desc().source,
                                       overrides_from(text, options), default_models));
            py::dict d;
            d["steps"] = check.steps;
            d["warnings"] = check.warnings;
            return d;
        },
        py::arg("scene"), py::arg("default_models") = "", py::arg("text") = py::dict(),
        "Integrator 'st' with the options a render would use (whatever their "
        "integrator): 'steps', per shape, whether it takes sphere steps there, and the "
        "'warnings' its render would give for media the models were not trained for.");
    m.def(
        "check_option_values",
        [](const py::dict& text, const py::kwargs& options) {
            check_override_values(overrides_from(text, options));
        },
        py::arg("text") = py::dict(),
        "Checks each option given (`text`: command-line strings; keyword arguments) on "
        "its own, before a scene is read: the messages of resolve_render_options.");
    m.def(
        "render",
        [](const Scene& scene, const std::string& default_models, py::object progress,
           const py::dict& text, int gpu_batch, int gpu_lanes, int first_sample,
           bool keep_film, int first_row, int rows, const py::kwargs& options) {
            RenderOptions opt =
                resolve_render_options(scene.desc().render, scene.desc().source,
                                       overrides_from(text, options), default_models);
            opt.gpu_batch = gpu_batch;
            opt.gpu_lanes = gpu_lanes;
            opt.first_sample = first_sample;
            opt.keep_film = keep_film;
            opt.first_row = first_row;
            opt.rows = rows;
            RenderProgress cb(progress);
            RenderResult r;
            {
                ReleasedGil release;
                r = render_with_backend(scene, opt, std::ref(cb));
            }
            cb.rethrow();
            py::dict d = film_dict(r, opt.spp, opt.record_paths, cb.interrupted);
            d["step_seconds"] = r.step_seconds;
            if (opt.backend == Backend::Vulkan) {
                d["gpu_seconds"] = r.gpu_seconds;
                d["device"] = r.device;
            }
            d["options"] = options_dict(opt);
            if (keep_film) d["film"] = film_sums(r.film);
            return d;
        },
        py::arg("scene"), py::arg("default_models") = "",
        py::arg("progress") = py::none(), py::arg("text") = py::dict(),
        py::arg("gpu_batch") = 0, py::arg("gpu_lanes") = 0, py::arg("first_sample") = 0,
        py::arg("keep_film") = false, py::arg("first_row") = 0, py::arg("rows") = 0,
        "Render with the resolved options (see resolve_render_options) on their "
        "backend. first_sample: render samples [first_sample, first_sample + spp) of "
        "every pixel; keep_film: return the film's sums as 'film' (sum, sum_sq, events, "
        "steps), for film_result; first_row, rows: render only those rows (CPU).");
    m.def(
        "film_result",
        [](py::array_t<double, py::array::c_style | py::array::forcecast> sum,
           py::array_t<double, py::array::c_style | py::array::forcecast> sum_sq,
           py::array_t<uint64_t, py::array::c_style | py::array::forcecast> events,
           py::array_t<uint64_t, py::array::c_style | py::array::forcecast> steps,
           int spp) {
            if (events.ndim() != 2) fail("film_result: events must be (height, width)");
            auto vec = [](const auto& a) {
                return std::vector(a.data(), a.data() + a.size());
            };
            const Film film(vec(sum), vec(sum_sq), vec(events), vec(steps));
            if (spp < 0) fail("film_result: spp must be >= 0, got ", spp);
            RenderResult r;
            r.height = int(events.shape(0));
            r.width = int(events.shape(1));
            film.finish(spp, r);
            return film_dict(r, spp, false, false);
        },
        py::arg("sum"), py::arg("sum_sq"), py::arg("events"), py::arg("steps"),
        py::arg("spp"),
        "The image, variance, events, sphere_steps, samples and totals of a film's sums "
        "(as render(keep_film=True) returns them, added over parts) of spp samples per "
        "pixel: what a render of those samples reports.");
    m.attr("DEFAULT_AOV_SAMPLES") = kDefaultAovSamples;
    m.def(
        "multiple_scattering_albedo", &multiple_scattering_albedo,
        py::arg("reduced_albedo"),
        "The multiple-scattering albedo (a thick slab's diffuse reflectance) of a medium "
        "of reduced single-scattering albedo sigma_s' / (sigma_s' + sigma_a): the "
        "forward direction of Chiang et al.'s fit (render/medium_presets.h).");
    m.def(
        "first_hit_aovs",
        [](const Scene& scene, py::object seed, py::object samples, py::object threads) {
            // seed and threads as a render takes them (types, ranges, messages); None,
            // which a render reads as "not given", is not a value here.
            if (seed.is_none())
                fail("seed must be an integer from 0 to 2^63 - 1, got None");
            if (threads.is_none())
                fail(
                    "threads must be an integer from 0 to 4096 (0 = all cores), got "
                    "None");
            py::kwargs kw;
            kw["seed"] = seed;
            kw["threads"] = threads;
            const RenderOptions r = resolve_render_options(
                RenderSettings(), "", overrides_from(py::dict(), kw), "");
            constexpr int kMaxSamples = std::numeric_limits<int32_t>::max();
            int n = 0;
            bool ok = !is_bool(samples) && PyIndex_Check(samples.ptr());
            if (ok) {
                const py::int_ v(samples);
                ok = v >= py::int_(1) && v <= py::int_(kMaxSamples);
                if (ok) n = v.cast<int>();
            }
            if (!ok)
                fail("aov samples must be an integer from 1 to ", kMaxSamples, ", got ",
                     std::string(py::repr(samples)));
            FirstHitAovs a;
            SignalStop ctrl_c;
            try {
                ReleasedGil release;
                a = first_hit_aovs(scene, r.seed, n, r.threads, ctrl_c.stop());
            } catch (const Cancelled&) {
                ctrl_c.rethrow();
            }
            const py::ssize_t H = a.height, W = a.width;
            py::dict d;
            d["albedo"] = to_array(a.albedo, {H, W, 3});
            d["normal"] = to_array(a.normal, {H, W, 3});
            d["depth"] = to_array(a.depth, {H, W});
            d["shape"] = to_array(a.shape, {H, W});
            return d;
        },
        py::arg("scene"), py::arg("seed") = 0, py::arg("samples") = kDefaultAovSamples,
        py::arg("threads") = 0,
        "First-hit albedo (H, W, 3), normal (H, W, 3) and depth (H, W) from the render's "
        "first `samples` camera rays of each pixel, and the shape index (H, W) the first "
        "ray hits (-1: a light or nothing) (render/aovs.h).");
}

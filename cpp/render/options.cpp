#include "render/options.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "core/check.h"
#include "render/integrators/list.h"

namespace sss {

namespace {

using Kind = OptionSpec::Kind;

std::string quoted_list(const std::vector<std::string>& choices) {
    std::string s;
    for (const std::string& c : choices) s += (s.empty() ? "'" : ", '") + c + "'";
    return s;
}

// The checks of one value. `label` names the option in messages: its name (spp), or
// its flag (--spp) where the command line gave it.
int64_t checked_integer(const std::string& name, int64_t v,
                        const std::string& label = "") {
    const OptionSpec& s = render_option_spec(name);
    if (v < s.lo || v > s.hi)
        fail(label.empty() ? name : label, " must be ", s.allowed, ", got ", v);
    return v;
}

std::string checked_choice(const std::string& name, const std::string& v,
                           const std::string& label = "") {
    const OptionSpec& s = render_option_spec(name);
    for (const std::string& c : s.choices)
        if (v == c) return v;
    fail(label.empty() ? name : label, " '", v,
         "' is not allowed (allowed: ", quoted_list(s.choices), ")");
}

// The scene file's render.time_limit has the same range (render/scene.cpp).
void check_time_limit(double seconds, const std::string& label = "time_limit") {
    if (!(seconds >= 0.0 && seconds <= 1e9))
        fail(label, " must be a number from 0 to 1e9 (seconds; 0: no limit), got ",
             seconds);
}

void check_sphere_threshold(double tau, const std::string& label = "sphere_threshold") {
    if (!(tau >= 0.0))
        fail(label, " must be a number >= 0 (inf: no sphere steps), got ", tau);
}

// The command line's flag of option `name`: --sphere-threshold.
std::string flag_of(const std::string& name) {
    std::string flag = "--" + name;
    for (char& c : flag)
        if (c == '_') c = '-';
    return flag;
}

// Checks each value `o` sets on its own; `as_flags`: messages name the flags.
void check_values(const RenderOverrides& o, bool as_flags) {
    auto label = [as_flags](const char* name) {
        return as_flags ? flag_of(name) : std::string(name);
    };
    for (const auto& [name, v] :
         {std::pair{"spp", o.spp}, std::pair{"seed", o.seed},
          std::pair{"threads", o.threads}, std::pair{"max_bounces", o.max_bounces}})
        if (v) checked_integer(name, *v, label(name));
    for (const auto& [name, v] :
         {std::pair{"integrator", o.integrator},
          std::pair{"sphere_sampler", o.sphere_sampler},
          std::pair{"step_nee", o.step_nee}, std::pair{"backend", o.backend}})
        if (v) checked_choice(name, *v, label(name));
    if (o.time_limit) check_time_limit(*o.time_limit, label("time_limit"));
    if (o.sphere_threshold)
        check_sphere_threshold(*o.sphere_threshold, label("sphere_threshold"));
}

}  // namespace

namespace {

// The integrator row's text, from the list of integrators.
struct IntegratorChoices {
    std::vector<std::string> choices;
    std::string help, allowed;
    IntegratorChoices() {
        const auto& names = integrator_names();
        for (size_t i = 0; i < names.size(); ++i) {
            const char* sep = i == 0 ? "" : (i + 1 == names.size() ? " or " : ", ");
            choices.push_back(names[i].name);
            help += sep + std::string(names[i].name) + " (" + names[i].help + ")";
            allowed += sep + std::string(names[i].name);
        }
        help += "; default: the scene's, else pt";
    }
};

}  // namespace

const std::vector<OptionSpec>& render_option_specs() {
    static const IntegratorChoices integrators;
    constexpr int64_t kMaxInt32 = std::numeric_limits<int32_t>::max();
    constexpr int64_t kMaxInt64 = std::numeric_limits<int64_t>::max();
    static const std::vector<OptionSpec> specs = {
        {"integrator", Kind::Choice, integrators.choices, "NAME",
         integrators.help.c_str(), true, integrators.allowed.c_str()},
        {"spp",
         Kind::Integer,
         {},
         "N",
         "samples per pixel (default: the scene's, else 16)",
         true,
         "an integer >= 1 (at most 16,777,216)",
         1,
         int64_t(1) << 24},
        {"seed",
         Kind::Integer,
         {},
         "N",
         "random seed (default: the scene's, else 0)",
         true,
         "an integer from 0 to 2^63 - 1",
         0,
         kMaxInt64},
        {"threads",
         Kind::Integer,
         {},
         "N",
         "CPU worker threads (default 0: all cores)",
         true,
         "an integer from 0 to 4096 (0 = all cores)",
         0,
         4096},
        {"max_bounces",
         Kind::Integer,
         {},
         "N",
         "scattering events per path, -1 = no limit (default: the scene's, else -1; st: "
         "-1 "
         "only)",
         true,
         "an integer from -1 (no limit) to 2147483647",
         -1,
         kMaxInt32},
        {"nee",
         Kind::Flag,
         {},
         "",
         "light sampling with MIS at every scattering event (on by default; without it "
         "emitters count only when paths hit them)",
         true,
         "True or False"},
        {"sphere_threshold",
         Kind::Number,
         {},
         "TAU",
         "st: a collision takes a sphere step where sigma_t * r >= TAU (default: the "
         "scene's, else 6; inf: never)",
         true,
         "a number >= 0 (inf: no sphere steps)"},
        {"models",
         Kind::Text,
         {},
         "DIR",
         "st: the directory of lengthgen.json, pathgen.json, eventgen.json (default: the "
         "scene's render.models, else the shipped models)",
         true,
         "a directory path"},
        {"cut_models",
         Kind::Text,
         {},
         "DIR",
         "st, experimental: cut sphere steps near the boundary, sampled by "
         "cutlengthgen.json and cutpathgen.json in DIR (models/cut; media "
         "whose scattering events get no light sampling, e.g. behind a smooth "
         "dielectric; "
         "default: none)",
         true,
         "a directory path"},
        {"sphere_sampler",
         Kind::Choice,
         {"model", "walk"},
         "NAME",
         "st: where steps come from: model (default) or walk (exact sphere walks, as "
         "slow "
         "as pt; CPU only)",
         true,
         "model or walk"},
        {"step_nee",
         Kind::Choice,
         {"hits", "event"},
         "NAME",
         "st: the direct light of a sphere step's events: hits (default: from its exit "
         "flight; under point and directional lights steps keep clear of the boundary "
         "and the point lights) or event (EventGen's representative event connects to "
         "every light; CPU only)",
         true,
         "hits or event"},
        {"backend",
         Kind::Choice,
         {"cpu", "vulkan"},
         "NAME",
         "cpu (default) or vulkan: the GPU path, on a GPU or on Mesa's lavapipe "
         "(docs/gpu.md)",
         true,
         "cpu or vulkan"},
        {"time_limit",
         Kind::Number,
         {},
         "S",
         "stop after S seconds of rendering with the passes every pixel has finished; "
         "spp stays the most it takes and defaults to unlimited (default: the scene's, "
         "else none)",
         true,
         "a number from 0 to 1e9 (seconds; 0: no limit)"},
        {"record_paths",
         Kind::Flag,
         {},
         "",
         "keep every path's event and step counts (8 bytes per path)",
         false,
         "True or False"},
    };
    return specs;
}

const OptionSpec& render_option_spec(const std::string& name) {
    for (const OptionSpec& s : render_option_specs())
        if (name == s.name) return s;
    std::string all;
    for (const OptionSpec& s : render_option_specs())
        all += (all.empty() ? "" : ", ") + std::string(s.name);
    fail("unknown render option '", name, "' (allowed: ", all, ")");
}

void set_override(RenderOverrides& o, const std::string& name, const OptionValue& v) {
    const OptionSpec& s = render_option_spec(name);
    const Kind given = std::holds_alternative<int64_t>(v)  ? Kind::Integer
                       : std::holds_alternative<double>(v) ? Kind::Number
                       : std::holds_alternative<bool>(v)   ? Kind::Flag
                                                           : Kind::Text;
    const bool text_kind = s.kind == Kind::Text || s.kind == Kind::Choice;
    if (given != s.kind && !(text_kind && given == Kind::Text))
        fail("internal: render option '", name, "' set with a value of another kind");
    if (name == "integrator") o.integrator = std::get<std::string>(v);
    if (name == "models") o.models = std::get<std::string>(v);
    if (name == "cut_models") o.cut_models = std::get<std::string>(v);
    if (name == "sphere_sampler") o.sphere_sampler = std::get<std::string>(v);
    if (name == "step_nee") o.step_nee = std::get<std::string>(v);
    if (name == "backend") o.backend = std::get<std::string>(v);
    if (name == "spp") o.spp = std::get<int64_t>(v);
    if (name == "seed") o.seed = std::get<int64_t>(v);
    if (name == "threads") o.threads = std::get<int64_t>(v);
    if (name == "max_bounces") o.max_bounces = std::get<int64_t>(v);
    if (name == "sphere_threshold") o.sphere_threshold = std::get<double>(v);
    if (name == "time_limit") o.time_limit = std::get<double>(v);
    if (name == "nee") o.nee = std::get<bool>(v);
    if (name == "record_paths") o.record_paths = std::get<bool>(v);
}

void set_override_from_text(RenderOverrides& o, const std::string& name,
                            const std::string& text) {
    const OptionSpec& s = render_option_spec(name);
    const std::string flag = flag_of(name);
    OptionValue value;
    switch (s.kind) {
        case Kind::Integer: {
            char* end = nullptr;
            errno = 0;
            const long long v = std::strtoll(text.c_str(), &end, 10);
            if (text.empty() || *end || errno == ERANGE)
                fail(flag, ": expected ", s.allowed, ", got '", text, "'");
            value = int64_t(v);
            break;
        }
        case Kind::Number: {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || *end || std::isnan(v))
                fail(flag, ": expected ", s.allowed, ", got '", text, "'");
            value = v;
            break;
        }
        case Kind::Text:
        case Kind::Choice:
            value = text;
            break;
        case Kind::Flag:
            if (text != "true" && text != "false")
                fail(flag, ": expected true or false, got '", text, "'");
            value = text == "true";
            break;
    }
    // The value on its own, under the flag's name ("--spp must be ...")
    RenderOverrides one;
    set_override(one, name, value);
    check_values(one, true);
    set_override(o, name, value);
}

void check_override_values(const RenderOverrides& o) { check_values(o, false); }

RenderOptions resolve_render_options(const RenderSettings& scene,
                                     const std::string& source, const RenderOverrides& o,
                                     const std::string& default_models) {
    RenderOptions r;
    // Defaults < scene < overrides, then every value checked.
    r.integrator = checked_choice("integrator", o.integrator.value_or(scene.integrator));
    r.time_limit = o.time_limit.value_or(scene.time_limit);
    check_time_limit(r.time_limit);
    // With a time limit and no spp given, the time alone ends the render.
    const int64_t default_spp =
        r.time_limit > 0 ? render_option_spec("spp").hi : kDefaultSpp;
    r.spp = int(checked_integer("spp", o.spp.value_or(scene.spp.value_or(default_spp))));
    r.seed = uint64_t(checked_integer("seed", o.seed.value_or(int64_t(scene.seed))));
    r.threads = int(checked_integer("threads", o.threads.value_or(0)));
    r.max_bounces =
        int(checked_integer("max_bounces", o.max_bounces.value_or(scene.max_bounces)));
    r.nee = o.nee.value_or(true);
    const double tau = o.sphere_threshold.value_or(scene.sphere_threshold);
    check_sphere_threshold(tau);
    r.sphere_threshold = float(tau);
    r.models = o.models                ? *o.models
               : !scene.models.empty() ? scene.models
                                       : default_models;
    r.cut_models = o.cut_models.value_or("");
    r.sphere_sampler =
        checked_choice("sphere_sampler", o.sphere_sampler.value_or("model")) == "walk"
            ? SphereSampler::Walk
            : SphereSampler::Model;
    r.step_nee = checked_choice("step_nee", o.step_nee.value_or("hits")) == "event"
                     ? StepNee::Event
                     : StepNee::Hits;
    r.backend = checked_choice("backend", o.backend.value_or("cpu")) == "vulkan"
                    ? Backend::Vulkan
                    : Backend::Cpu;
    r.record_paths = o.record_paths.value_or(false);
    // models and sphere_threshold have scene-file values that any integrator takes (a
    // scene may name them for when "st" is chosen), but given here with another
    // integrator they would be ignored: said, not ignored.
    for (const auto& [name, given] :
         {std::pair{"models", bool(o.models)},
          std::pair{"sphere_threshold", bool(o.sphere_threshold)}})
        if (given && r.integrator != "st")
            fail(source.empty() ? "" : source + ": ", name,
                 " is an option of integrator 'st' (the integrator is '", r.integrator,
                 "')");
    check_render_options(r, source);
    return r;
}

void check_render_options(const RenderOptions& r, const std::string& source) {
    // Values (those resolve_render_options parsed are checked again: cheap)
    checked_choice("integrator", r.integrator);
    check_time_limit(r.time_limit);
    checked_integer("spp", r.spp);
    const int64_t max_samples = render_option_spec("spp").hi;
    if (r.first_sample < 0 || int64_t(r.first_sample) + r.spp > max_samples)
        fail("first_sample ", r.first_sample, " with spp ", r.spp,
             ": the samples of a pixel are numbered 0 to ", max_samples - 1);
    checked_integer("threads", r.threads);
    checked_integer("max_bounces", r.max_bounces);
    check_sphere_threshold(r.sphere_threshold);

    // Combinations
    const std::string where = source.empty() ? "" : source + ": ";
    if (r.integrator == "st" && r.max_bounces != -1)
        fail(where, "max_bounces ", r.max_bounces,
             " is not supported by integrator 'st' (allowed: -1): a sphere step stands "
             "for many scattering events at once");
    if (!r.cut_models.empty() && r.integrator != "st")
        fail(where, "cut_models is an option of integrator 'st' (the integrator is '",
             r.integrator, "')");
    // The other "st" options have defaults that any integrator takes. (Checked before the
    // backend's: with "pt" they are wrong on either backend.)
    if (r.integrator != "st" && r.step_nee != StepNee::Hits)
        fail(where,
             "step_nee 'event' is an option of integrator 'st' (the integrator is '",
             r.integrator, "')");
    if (r.integrator != "st" && r.sphere_sampler != SphereSampler::Model)
        fail(where,
             "sphere_sampler 'walk' is an option of integrator 'st' (the integrator is '",
             r.integrator, "')");
    if (r.backend == Backend::Vulkan) {
        if (r.threads != 0)
            fail("threads=", r.threads,
                 " is CPU-only (backend 'vulkan' uses the GPU's own; allowed: 0)");
        if (r.step_nee != StepNee::Hits)
            fail(
                "step_nee 'event' is CPU-only (backend 'vulkan' has step_nee 'hits' "
                "only)");
        if (r.sphere_sampler != SphereSampler::Model)
            fail(
                "sphere_sampler 'walk' is CPU-only (backend 'vulkan' samples steps with "
                "the models)");
    }
}

const char* to_string(StepNee v) { return v == StepNee::Event ? "event" : "hits"; }
const char* to_string(SphereSampler v) {
    return v == SphereSampler::Walk ? "walk" : "model";
}
const char* to_string(Backend v) { return v == Backend::Vulkan ? "vulkan" : "cpu"; }

}  // namespace sss

// The render options, defined once: what a render takes (RenderOptions), what a caller
// may override (RenderOverrides), and the table both command lines and the Python API are
// built from (render_option_specs). A render's options are resolved once, in
// resolve_render_options: the defaults below < the scene file's "render" block < the
// caller's overrides (command line or keyword arguments). docs/options.md lists them.
// Header-only types, so the GPU layer (which links no render code) uses them too.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace sss {

// Default sphere_threshold tau of integrator "st": a collision at p takes a sphere step
// when sigma_t * r(p) >= tau. Chosen by measurement (render time against image error on
// the sphere and bunny scenes): docs/sphere-tracing.md, "Choosing the threshold".
constexpr float kDefaultSphereThreshold = 6.f;

// Where "st" takes its steps from: the learned models, or exact sphere walks (cpp/media;
// as slow as path tracing, for validating the integrator without model error).
enum class SphereSampler { Model, Walk };

// How a sphere step's events get their direct light
// (docs/sphere-tracing.md#nee-for-a-sphere-step).
//   Hits:  no light sampling at the step's events for area lights and the environment;
//          their direct light is what the step's exit flight collects when it reaches a
//          light (weight 1). Point and directional lights, which no flight can hit, are
//          kept away instead: the step's ball keeps kDeltaLightClearance mean free paths
//          from the boundary and the point lights (SphereTracing::clearance). Never
//          evaluates EventGen.
//   Event: the paper's: EventGen's representative event gets a connection to one light
//          chosen among all, weighted by Lambda, with the MIS rule of the docs.
enum class StepNee { Hits, Event };

enum class Backend { Cpu, Vulkan };

constexpr int kDefaultSpp = 16;

// record_paths keeps 8 bytes per path, for at most this many paths.
constexpr uint64_t kMaxRecordedPaths = uint64_t(1) << 27;

// A render's options, resolved and checked.
struct RenderOptions {
    std::string integrator = "pt";  // "pt" (path tracing) or "st" (sphere tracing)
    int spp = kDefaultSpp;
    uint64_t seed = 0;
    int threads = 0;       // CPU worker threads; 0 = all cores
    int max_bounces = -1;  // scattering events per path; -1 = no limit ("st": only -1)
    bool nee = true;       // next-event estimation (light sampling with MIS)
    // "st": a collision at p takes a sphere step when sigma_t * r(p) >= sphere_threshold
    // (>= 0; infinity: never, the image is then bit-identical to "pt").
    float sphere_threshold = kDefaultSphereThreshold;
    std::string models;  // "st": the directory of lengthgen/pathgen/eventgen.json
    // "st": the directory of cutlengthgen/cutpathgen.json; empty: no cut sphere steps.
    std::string cut_models;
    SphereSampler sphere_sampler = SphereSampler::Model;
    StepNee step_nee = StepNee::Hits;  // "st" with nee
    // Keep every path's event and step counts (8 bytes per path, at most
    // kMaxRecordedPaths paths).
    bool record_paths = false;
    Backend backend = Backend::Cpu;
    // Vulkan, for benchmarks (no result depends on them): samples per pixel per dispatch
    // (0: sized by time) and invocations per dispatch (0: one path each).
    int gpu_batch = 0, gpu_lanes = 0;
    // Seconds of rendering after which the render stops with the passes every pixel has
    // finished (at least one sample per pixel); spp stays the most it takes. 0: none.
    double time_limit = 0.0;
    // One part of a render split by sample ranges (python/sssphere/cluster.py): this
    // render takes samples [first_sample, first_sample + spp) of every pixel, each with
    // the random stream it has in a whole render, and keep_film returns its film's sums
    // (RenderResult::film) for adding to the other parts'. Not in the option table:
    // callers set them directly.
    int first_sample = 0;
    bool keep_film = false;
    // Only the image rows [first_row, first_row + rows) are rendered (a band of a render
    // split by tiles; the others stay 0); rows = 0: all. CPU only.
    int first_row = 0, rows = 0;
};

// A caller's overrides: every option it sets; the others come from the scene file's
// "render" block, else RenderOptions' defaults. Values are as given, checked when
// resolved.
struct RenderOverrides {
    std::optional<std::string> integrator, models, cut_models, sphere_sampler, step_nee,
        backend;
    std::optional<int64_t> spp, seed, threads, max_bounces;
    std::optional<double> sphere_threshold, time_limit;
    std::optional<bool> nee, record_paths;
};

// One row of the option table. `name` is the Python keyword and, with '_' written '-',
// the command-line flag (--sphere-threshold); a Flag whose default is on is given as
// --no-NAME on the command line.
struct OptionSpec {
    enum class Kind { Integer, Number, Text, Choice, Flag };
    const char* name;
    Kind kind;
    std::vector<std::string> choices;  // Choice only
    const char* metavar;               // the value's name in --help ("N", "TAU", "DIR")
    const char* help;
    bool command_line;       // offered by both command lines (else Python only)
    const char* allowed;     // what it takes, for messages ("an integer >= 1")
    int64_t lo = 0, hi = 0;  // Integer: the range
};
// The row of option `name`; throws sss::Error naming the options there are.
const OptionSpec& render_option_spec(const std::string& name);
const std::vector<OptionSpec>& render_option_specs();

// A value of an option's kind: Integer, Number, Flag; Text and Choice take the string.
using OptionValue = std::variant<int64_t, double, std::string, bool>;
// Sets override `name` (checked when resolved). Throws sss::Error for an unknown name.
void set_override(RenderOverrides& o, const std::string& name, const OptionValue& value);

// Sets override `name` from its command-line text, checked: its form ("--spp: expected an
// integer >= 1, got 'x'") and its value on its own ("--spp must be an integer >= 1 ...,
// got 0"), the command lines' usage errors. Flags take "true" or "false". Throws
// sss::Error.
void set_override_from_text(RenderOverrides& o, const std::string& name,
                            const std::string& text);

// Checks each value `o` sets on its own (a range, a choice; not their combinations, which
// depend on the scene): the command lines call it before reading a scene, so a bad option
// is refused at once, not after seconds of building. Throws sss::Error, with the messages
// of resolve_render_options.
void check_override_values(const RenderOverrides& o);

// The scene file's "render" block (docs/scene-format.md), as read: what it sets of a
// render's options.
struct RenderSettings {
    std::string integrator = "pt";
    std::optional<int>
        spp;  // unset: RenderOptions' default (unlimited with a time limit)
    uint64_t seed = 0;
    int max_bounces = -1;     // scattering events per path; -1 = no limit
    double time_limit = 0.0;  // seconds of rendering; 0: no limit
    // Distance-grid cells along a shape's largest side; 0 = per shape, by its medium
    // (Scene::auto_grid_resolution).
    int grid_resolution = 0;
    float sphere_threshold =
        kDefaultSphereThreshold;  // "st": optical radius of the smallest step
    std::string
        models;  // "st": model directory (resolved against the scene file's); "" = unset
};

// The options of one render: defaults < scene < overrides, every value checked, with
// errors that name the option, the value and what is allowed. `source` names the scene in
// messages; `default_models` is the models directory when neither the overrides nor the
// scene give one ("" = none). Throws sss::Error.
RenderOptions resolve_render_options(const RenderSettings& scene,
                                     const std::string& source,
                                     const RenderOverrides& overrides,
                                     const std::string& default_models);

// Checks every value of `options` and their combinations, with the messages of
// resolve_render_options (which calls it): both renderers call it first, so options made
// in C++ without resolving are held to the same rules. `source` names the scene in
// messages about combinations. Throws sss::Error.
void check_render_options(const RenderOptions& options, const std::string& source);

const char* to_string(StepNee v);
const char* to_string(SphereSampler v);
const char* to_string(Backend v);

}  // namespace sss

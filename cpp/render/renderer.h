// The CPU renderer: "pt" or "st" on worker threads, in passes (1, 2, 4, ... samples per
// pixel, then spp/16 each) over 16x16 tiles, by the shared render loop
// (render/scheduler.h). Each (pixel, sample) has its own random stream and whole passes
// are added to the film in order, so the result is bit-identical for any thread count.
// Stopping early (the progress callback returning false, or RenderOptions::time_limit)
// keeps every pass all pixels have finished, so every pixel has the same samples
// (RenderResult::spp).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "render/film.h"
#include "render/options.h"
#include "render/scene.h"
#include "render/sphere_tracing.h"

namespace sss {

RenderResult render(const Scene& scene, const RenderOptions& options,
                    const ProgressFn& progress = {});

// Integrator "st" with these options, whatever options.integrator says: which media take
// sphere steps (SphereTracing::can_step: deep enough, and the models trained for them),
// and the warnings it gives for those the models were not trained for (the cut models'
// checks are left to the render). Before a render, so that the command lines and Python
// say them when it starts and `sssphere info` predicts no steps there. Throws what
// SphereTracing's constructor throws (no models, a threshold below their range).
struct SphereStepCheck {
    std::vector<bool> steps;  // per shape (false for surfaces)
    std::vector<std::string> warnings;
};
SphereStepCheck check_sphere_steps(const Scene& scene, const RenderOptions& options);

}  // namespace sss

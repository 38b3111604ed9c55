// Film and multithreaded rendering. The image is rendered in passes (1, 2, 4, ... samples
// per pixel, then spp/16 each) over 16x16 tiles; each (pixel, sample) has its own random
// stream, and whole passes are added to the film in order, so the result is
// bit-identical for any thread count. Stopping early (the progress callback returning
// false, or RenderOptions::time_limit) keeps every pass all pixels have finished, so
// every pixel has the same samples (RenderResult::spp).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "render/options.h"
#include "render/scene.h"
#include "render/sphere_tracing.h"

namespace sss {

struct RenderResult {
    int width = 0, height = 0;
    std::vector<float> image;     // (height, width, 3) mean radiance
    std::vector<float> variance;  // (height, width, 3) variance of that mean
    std::vector<float>
        events;  // (height, width) mean ordinary scattering events per path
    std::vector<float> sphere_steps;  // (height, width) mean sphere steps per path ("st")
    std::vector<uint32_t> samples;    // (height, width) samples taken
    // With record_paths: (spp, height, width) ordinary events and sphere steps of each
    // path, sample k of a pixel at [k][y][x]; 0 for the samples not taken (k >= samples).
    std::vector<uint32_t> path_events, path_steps;
    double seconds = 0.0;
    // Time spent sampling sphere steps (decoders, frames; "st"), summed over the threads:
    // divided by total_sphere_steps, the cost of one step in the render.
    double step_seconds = 0.0;
    int spp = 0;  // samples every pixel has: the options' spp unless stopped early
    bool cancelled = false;           // stopped by the progress callback (Ctrl-C)
    bool time_limit_reached = false;  // stopped by RenderOptions::time_limit
    uint64_t total_events = 0;
    uint64_t total_sphere_steps = 0;
    uint64_t total_paths = 0;
    // Backend::Vulkan: the GPU time of the dispatches (timestamps) and the device's name.
    double gpu_seconds = 0.0;
    std::string device;
};

// Called from the calling thread about ten times a second with the fraction done; return
// false to stop early.
using ProgressFn = std::function<bool(double)>;

RenderResult render(const Scene& scene, const RenderOptions& options,
                    const ProgressFn& progress = {});

}  // namespace sss

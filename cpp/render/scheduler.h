// The render loop both renderers share (the CPU one in render/renderer.cpp, the Vulkan
// one in gpu/gpu_renderer.cpp): which samples are taken when, accumulation into the film,
// progress, cancellation and the time limit. A renderer only says how to render one
// piece of work (TileFn); docs/architecture.md has the picture.
//
// Samples are taken in progressive passes: pass p gives every pixel the samples
// [s0, s1) (a range of sample indices, so the results cannot depend on how the passes
// fall when every sample has its own random stream). A pass is cut into tiles; finished
// tiles wait until every tile of their pass has finished, and whole passes are then added
// to the film in order. So every pixel always holds the same samples, a render stopped
// early (cancelled or out of time) is a render of fewer samples per pixel, and the
// floating-point sums do not depend on the thread count.
#pragma once

#include <atomic>
#include <functional>
#include <limits>

#include "render/film.h"

namespace sss {

// How the passes grow. Pass 0 has `first` samples per pixel, each later one `growth`
// times the one before, at most `max_size`; once a speed has been measured, a pass also
// takes at most what renders in `target_seconds` at that speed (and, with a time limit,
// in the time left). The sizes depend on timing only where target_seconds is finite or
// a time limit is set.
struct PassPolicy {
    int first = 1;
    int growth = 2;
    int max_size = 1;
    double target_seconds = std::numeric_limits<double>::infinity();
};

struct ScheduleOptions {
    int width = 0, height = 0;
    int spp = 1;
    // The sample indices start here: the tiles get samples [first_sample, first_sample +
    // spp), the passes count from first_sample (a part of a render split by samples).
    int first_sample = 0;
    // Only rows [row0, row1) are rendered (a band of a render split by tiles); row1 = 0:
    // to the last row. The film still holds the whole image.
    int row0 = 0, row1 = 0;
    int tile = 16;  // tiles of tile x tile pixels (smaller in the last row and column)
    // Worker threads rendering the tiles, while the calling thread reports progress,
    // relays cancellation and keeps the time limit about ten times a second. 0: the
    // calling thread renders the tiles itself, in order, and does those between tiles
    // (for the Vulkan renderer, whose tiles are dispatches that end within a second).
    int threads = 1;
    double time_limit = 0.0;  // seconds; 0: none
    PassPolicy passes;
};

// One piece of work: samples [s0, s1) of every pixel in [x0, x1) x [y0, y1).
struct TileWork {
    int x0, y0, x1, y1, s0, s1;
    int width() const { return x1 - x0; }
    int pixels() const { return (x1 - x0) * (y1 - y0); }
};

// Renders `work` into `film` (the work's pixels in row order). Returns false if it saw
// `cancel`, which may have cut a path short (the scheduler then drops the tile). Called
// from the worker threads, several at once: it must be thread-safe. An exception stops
// the render and is rethrown by schedule().
using TileFn = std::function<bool(const TileWork& work, Film& film,
                                  const std::atomic<bool>& cancel)>;

struct Scheduled {
    Film film{0};  // width * height pixels, row order: the passes all tiles finished
    int spp = 0;   // samples per pixel in `film`
    bool cancelled = false;           // the progress callback returned false
    bool time_limit_reached = false;  // stopped by ScheduleOptions::time_limit
    double seconds = 0.0;             // wall time
};

// Runs the passes until spp samples per pixel, a cancel or the time limit (which stops
// the render once the first pass is in: a time-limited render has at least one sample
// per pixel). progress (may be empty) gets the fraction done on the calling thread.
Scheduled schedule(const ScheduleOptions& options, const TileFn& render_tile,
                   const ProgressFn& progress);

}  // namespace sss

// The film: per-pixel sums of a render's samples, and the result a finished render
// reports (RenderResult). One film for both renderers, filled by their shared scheduler
// (render/scheduler.h): the CPU renderer (render/renderer.cpp) renders tiles, the Vulkan
// one (gpu/gpu_renderer.cpp) whole images per dispatch.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/check.h"

namespace sss {

struct RenderResult;

// Called from the calling thread with the fraction done (the CPU renderer about ten
// times a second, the Vulkan one between dispatches); return false to stop early.
using ProgressFn = std::function<bool(double)>;

// Sums over the samples of each of `pixels` pixels: radiance and its square (for the
// variance of the mean), ordinary scattering events and sphere steps. A tile of the CPU
// renderer is a Film too, added to the image's film pixel by pixel.
class Film {
public:
    explicit Film(size_t pixels)
        : sum_(pixels * 3, 0.0),
          sum_sq_(pixels * 3, 0.0),
          events_(pixels, 0),
          steps_(pixels, 0) {}

    size_t pixels() const { return events_.size(); }

    // One sample of pixel p (radiance[0 .. 2]: a Vec3 or a pointer to floats).
    template <class Rgb>
    void add_sample(size_t p, const Rgb& radiance, uint64_t events, uint64_t steps) {
        for (int c = 0; c < 3; ++c) {
            const double v = radiance[c];
            sum_[3 * p + c] += v;
            sum_sq_[3 * p + c] += v * v;
        }
        events_[p] += events;
        steps_[p] += steps;
    }

    // The sums of pixel q of `other` added to pixel p.
    void add_pixel(size_t p, const Film& other, size_t q) {
        for (int c = 0; c < 3; ++c) {
            sum_[3 * p + c] += other.sum_[3 * q + c];
            sum_sq_[3 * p + c] += other.sum_sq_[3 * q + c];
        }
        events_[p] += other.events_[q];
        steps_[p] += other.steps_[q];
    }

    // Sums of pixels() pixels, as sums() gives them (of another film, e.g. a part of a
    // render made elsewhere): 3 radiance sums and 3 sums of squares per pixel, then one
    // event and one step count. Throws sss::Error when the sizes disagree.
    Film(std::vector<double> sum, std::vector<double> sum_sq,
         std::vector<uint64_t> events, std::vector<uint64_t> steps)
        : sum_(std::move(sum)),
          sum_sq_(std::move(sum_sq)),
          events_(std::move(events)),
          steps_(std::move(steps)) {
        const size_t n = events_.size();
        if (sum_.size() != 3 * n || sum_sq_.size() != 3 * n || steps_.size() != n)
            fail("a film of ", n, " pixels needs ", 3 * n, " radiance sums, ", 3 * n,
                 " sums of squares and ", n, " step counts; got ", sum_.size(), ", ",
                 sum_sq_.size(), " and ", steps_.size());
    }

    const std::vector<double>& sums() const { return sum_; }
    const std::vector<double>& sums_of_squares() const { return sum_sq_; }
    const std::vector<uint64_t>& event_counts() const { return events_; }
    const std::vector<uint64_t>& step_counts() const { return steps_; }

    // Adds every pixel of `other` (of as many pixels) to this film's.
    void add(const Film& other) {
        if (other.pixels() != pixels())
            fail("cannot add a film of ", other.pixels(), " pixels to one of ", pixels());
        for (size_t p = 0; p < pixels(); ++p) add_pixel(p, other, p);
    }

    // Fills r's images, samples, spp and totals from spp samples in every pixel: the
    // mean, the variance of the mean (the sample variance / spp), events and steps per
    // path. spp = 0 (stopped before any) gives zeros.
    void finish(int spp, RenderResult& r) const;

private:
    std::vector<double> sum_, sum_sq_;
    std::vector<uint64_t> events_, steps_;
};

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
    double seconds = 0.0;  // wall time of the render
    // Time spent sampling sphere steps (decoders, frames; "st" on the CPU), summed over
    // the threads: divided by total_sphere_steps, the cost of one step in the render.
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
    // What the render says, one line each: e.g. media that "st" renders without steps,
    // as the models were not trained for them.
    std::vector<std::string> warnings;
    // With RenderOptions::keep_film: the film's sums, to add to other parts of a render
    // split by sample ranges; else empty.
    Film film{0};
};

inline void Film::finish(int spp, RenderResult& r) const {
    const size_t pixels = this->pixels();
    r.image.assign(pixels * 3, 0.f);
    r.variance.assign(pixels * 3, 0.f);
    r.events.assign(pixels, 0.f);
    r.sphere_steps.assign(pixels, 0.f);
    r.samples.assign(pixels, uint32_t(spp));
    r.spp = spp;
    r.total_paths = uint64_t(spp) * pixels;
    r.total_events = r.total_sphere_steps = 0;
    const double n = spp;
    for (size_t p = 0; p < pixels && spp > 0; ++p) {
        r.total_events += events_[p];
        r.total_sphere_steps += steps_[p];
        r.events[p] = float(double(events_[p]) / n);
        r.sphere_steps[p] = float(double(steps_[p]) / n);
        for (int c = 0; c < 3; ++c) {
            const double mean = sum_[3 * p + c] / n;
            r.image[3 * p + c] = float(mean);
            const double var =
                n > 1 ? std::max(0.0, (sum_sq_[3 * p + c] - n * mean * mean) / (n - 1))
                      : 0.0;
            r.variance[3 * p + c] = float(var / n);
        }
    }
}

// With RenderOptions::record_paths: the ordinary events and sphere steps of every path,
// sample k of pixel p at k * pixels + p (RenderResult::path_events, path_steps).
class PathRecord {
public:
    explicit PathRecord(size_t paths) : events_(paths, 0), steps_(paths, 0) {}
    bool on() const { return !events_.empty(); }
    void set(size_t at, uint32_t events, uint32_t steps) {
        events_[at] = events;
        steps_[at] = steps;
    }
    // Moves the records into r; those from `kept` on (samples traced but not in the film,
    // as of a stopped render) become 0.
    void finish(size_t kept, RenderResult& r) {
        if (!on()) return;
        std::fill(events_.begin() + std::min(kept, events_.size()), events_.end(), 0u);
        std::fill(steps_.begin() + std::min(kept, steps_.size()), steps_.end(), 0u);
        r.path_events = std::move(events_);
        r.path_steps = std::move(steps_);
    }

private:
    std::vector<uint32_t> events_, steps_;
};

}  // namespace sss

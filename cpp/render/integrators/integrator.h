// An integrator renders pieces of work, each the samples [s0, s1) of a tile of pixels,
// into a film; the render loop (render/scheduler.h) does everything else: passes, tiles,
// threads, progress, Ctrl-C, the time limit. One file per integrator in this folder
// (pt.cpp, st.cpp), each defining <name>_integrator_kind(), and one entry in list.h
// (docs/extending.md).
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "render/camera.h"
#include "render/film.h"
#include "render/integrators/list.h"
#include "render/options.h"
#include "render/pt.h"
#include "render/scene.h"
#include "render/scheduler.h"

namespace sss {

// What an integrator is made from: the scene, the checked options, the camera, and where
// each path's counts go (record_paths; PathRecord::on() says whether they are kept).
struct IntegratorSetup {
    const Scene& scene;
    const RenderOptions& options;
    const PinholeCamera& camera;
    PathRecord& paths;
};

class Integrator {
public:
    virtual ~Integrator() = default;
    // Renders `work` into `film` (the work's pixels in row order); false if it saw
    // `cancel` (a path may then have been cut short). Called from several worker threads
    // at once.
    virtual bool render_tile(const TileWork& work, Film& film,
                             const std::atomic<bool>& cancel) = 0;
    // Seconds spent sampling sphere steps, summed over the tiles (RenderResult).
    virtual double step_seconds() const { return 0.0; }
    // What the render should say, one line each (RenderResult::warnings).
    virtual std::vector<std::string> warnings() const { return {}; }
};

struct IntegratorKind {
    const char* name = "";  // the `integrator` option's value
    std::function<std::unique_ptr<Integrator>(const IntegratorSetup&)> make;
};

// The integrator the options name (they are checked: it exists).
const IntegratorKind& integrator_kind(const std::string& name);

// The camera paths of one piece of work, for integrators that trace paths from the
// camera: sample k of the tile's pixel i (in row order) is work item i * m + (k - s0),
// m = s1 - s0, and draws from the stream of (seed, pixel, sample), so a pixel's samples
// do not depend on the tiling.
class TileSamples {
public:
    TileSamples(const IntegratorSetup& setup, const TileWork& work)
        : setup_(setup), work_(work), m_(work.s1 - work.s0) {}
    int items() const { return work_.pixels() * m_; }
    int samples_per_pixel() const { return m_; }
    // Starts item's path: the camera ray through its jittered pixel position.
    void start(int item, const PathTracer& tracer, PathState& ps) const;
    // Adds item's finished path to the film (and to the path record, if kept).
    void record(int item, const PathSample& sample, Film& film) const;

private:
    void pixel(int item, int& x, int& y) const {
        x = work_.x0 + (item / m_) % work_.width();
        y = work_.y0 + (item / m_) / work_.width();
    }
    const IntegratorSetup& setup_;
    const TileWork& work_;
    int m_;
};

// Traces every item of `samples` with `tracer` one path at a time (no sphere steps);
// false if cancelled (checked before each path, and by the paths themselves).
bool trace_paths(const TileSamples& samples, const PathTracer& tracer, Film& film,
                 const std::atomic<bool>& cancel);

// The factories of list.h's integrators, one per file.
#define SSS_INTEGRATOR_FACTORY(name, help) IntegratorKind name##_integrator_kind();
SSS_INTEGRATORS(SSS_INTEGRATOR_FACTORY)
#undef SSS_INTEGRATOR_FACTORY

}  // namespace sss

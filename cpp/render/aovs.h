// First-hit AOVs (arbitrary output variables) for compositing and denoising: what the
// camera ray of a pixel meets first, averaged over the first `samples` camera rays of the
// pixel (the render's own rays: the same seed gives the same jitter). They depend on the
// scene, the camera and the seed alone, not on the integrator or the backend, and cost
// one Embree query per ray.
//
//   albedo: a medium's multiple-scattering albedo (the colour a thick slab of it
//           reflects, render/medium_presets.h) whatever its boundary; a surface's colour;
//           1 for an area light; 0 where the ray leaves the scene.
//   normal: the unit normal of the triangle hit, turned to face the camera; 0 on a miss.
//   depth:  the distance from the camera to the hit along the ray; 0 on a miss.
//   shape:  the index of the shape the pixel's first ray hits; -1 for a light or nothing
//           (an object-ID mask; not averaged).
// Each is the mean over the rays, so edges are antialiased (a normal there is shorter
// than 1).
#pragma once

#include <cstdint>
#include <vector>

#include "core/cancel.h"
#include "render/scene.h"

namespace sss {

// Camera rays per pixel the AOVs average unless told otherwise: noise-free enough for a
// denoiser's guides (OIDN's), cheap beside any render.
constexpr int kDefaultAovSamples = 16;

struct FirstHitAovs {
    int width = 0, height = 0, samples = 0;
    std::vector<float> albedo;   // (height, width, 3)
    std::vector<float> normal;   // (height, width, 3)
    std::vector<float> depth;    // (height, width)
    std::vector<int32_t> shape;  // (height, width)
};

// The AOVs of the scene's camera from `samples` >= 1 rays per pixel (render sample
// indices 0 .. samples-1 under `seed`), on `threads` threads (0: every core). The result
// does not depend on the thread count. `stop` is polled every few thousand rays; once it
// returns true the call throws Cancelled (core/cancel.h).
FirstHitAovs first_hit_aovs(const Scene& scene, uint64_t seed, int samples, int threads,
                            const StopFn& stop = {});

// The albedo the AOV gives a medium's boundary, per channel.
Vec3 medium_aov_albedo(const Medium& medium);

}  // namespace sss

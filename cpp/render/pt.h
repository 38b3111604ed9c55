// The ground-truth volumetric path tracer (integrator "pt"): delta tracking in
// homogeneous media with Henyey-Greenstein scattering, index-matched and smooth
// dielectric boundaries, next-event estimation toward one light at every scattering event
// (MIS with phase sampling for area and environment lights). See docs/notation.md for the
// conventions.
//
// With a SphereTracing policy it is the sphere tracer (integrator "st",
// docs/sphere-tracing.md): at a real collision deep enough inside a medium one learned
// sphere step replaces the scattering events inside the largest sphere there; everything
// else (flights, boundaries, lights, NEE, roulette) is the same code.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "core/rng.h"
#include "core/vec.h"
#include "render/scene.h"
#include "render/sphere_tracing.h"

namespace sss {

struct PathSample {
    Vec3 radiance;
    uint32_t scatter_events =
        0;  // ordinary scattering events (real collisions scattered by HG)
    uint32_t sphere_steps =
        0;  // sphere steps ("st" only), each standing for N >= 1 events
};

// One path between calls of PathTracer::advance: the loop's state, and its random stream.
struct PathState {
    Rng rng;
    Vec3 o, d;  // position and direction
    Vec3 L{0.f}, beta{1.f};
    float beta_start = 1.f;
    // Chromatic media (docs/notation.md, "Colour"): "pt" samples flights with the hero
    // channel's extinction and carries all three channels with spectral MIS (`ratio`:
    // each channel's pdf of the path so far over the hero channel's, so that a vertex
    // contributes beta / mean(ratio)); "st" does so until its first sphere step, and then
    // carries one channel, picked afresh (beta = 3 e_c times the weight there).
    int channel = -1;       // the hero or carried channel; -1: grey media, any channel
    bool spectral = false;  // spectral MIS (chromatic media, until "st" steps)
    Vec3 ratio{1.f};
    int shape = -1;  // the shape whose medium holds the photon; -1 = vacuum
    // The last vertex did no light sampling that an emitter hit now must share with: the
    // camera, a specular interface, or a sphere step with StepNee::Hits (weight 1).
    bool specular = true;
    float phase_pdf = 0.f;  // pdf of the direction sampled at the last scattering event
    Vec3 scatter_pos;       // where that event happened (light pdfs are measured from it)
    float r_at_o = -1.f;  // the distance grid's bound at o when known (0 on the surface),
                          // else < 0
    PathSample out;
    StepRequest step;  // valid while the path waits for a sphere step
    // The render's stop flag, checked every 65536 events: set, the path ends where it
    // is (its tile is dropped). Kept by PathTracer::start. nullptr: never stops.
    const std::atomic<bool>* cancel = nullptr;
};

class PathTracer {
public:
    // nee = false: no light sampling, emitters count only when paths hit them (for tests
    // of the MIS weights, and as the plain estimator).
    // sphere_tracing: the policy of integrator "st" (not owned; must outlive the tracer),
    // or nullptr for "pt".
    PathTracer(const Scene& scene, int max_bounces, bool nee = true,
               const SphereTracing* sphere_tracing = nullptr);
    // Radiance arriving at `o` from direction -d (a camera ray o + t d), the whole path
    // at once (a sphere step is sampled on its own: "st" renders use start / advance).
    PathSample trace(const Vec3& o, const Vec3& d, Rng& rng) const;

    // The same path in pieces, so that several paths can share the decoders: start() sets
    // up the camera ray o + t d; advance() runs the path until it ends (returns true;
    // the result is in state.out) or needs a sphere step (false; state.step says which).
    // The next advance() takes that step, sampled by SphereTracing::sample_group. The
    // random numbers a path consumes, and so its result, do not depend on how paths are
    // grouped.
    void start(PathState& state, const Vec3& o, const Vec3& d, const Rng& rng) const;
    bool advance(PathState& state, const WorldSphereStep* step = nullptr) const;

private:
    // The path loop; kSphereTracing = (st_ != nullptr), so "pt" compiles without the
    // step.
    template <bool kSphereTracing>
    bool run(PathState& state, const WorldSphereStep* step) const;
    // The face of medium `shape` under a surface where the ray, inside it, hits the
    // surface (Scene::other_at; Scene::surface_at is the converse).
    bool face_at(const Vec3& o, const Vec3& d, const Hit& surface, int shape,
                 Hit* face) const;
    // "st": applies the sphere step the path waited for (weights, NEE from its
    // representative event, the exit) to its state; false when the path ends there.
    bool take_step(PathState& state, const WorldSphereStep& step) const;
    // "st": fills state.step, the request for a step at the path's position, in a ball
    // of radius r (the grid's bound, or SphereTracing::step_radius's).
    void request_step(PathState& state, float r) const;
    // "st" with cut_models: fills state.step, the request for a cut sphere step at the
    // path's position, where the plane certificate gives normal n and distance s.
    void request_cut_step(PathState& state, Vec3 n, float s) const;
    // Scattering x transmittance x emitted radiance / pdf at the path vertex p from one
    // light chosen uniformly (weighted by the number of lights; delta_only: among the
    // point and directional lights), with MIS against the vertex's own sampled
    // continuation; mis = false: see direct_light. `scatter` is the
    // vertex's scattering (MediumScatter, SurfaceScatter or BoundaryScatter in pt.cpp:
    // its value and pdf towards a direction, where its shadow rays start and in which
    // medium, its phase function if any).
    template <class Scatter>
    Vec3 sample_light(const Vec3& p, const Scatter& scatter, Rng& rng, bool mis = true,
                      bool delta_only = false) const;
    // Phase x transmittance x emitted radiance / pdf at medium point p of shape `shape`
    // (r: the distance grid's bound at p, or < 0 to query it), for a photon travelling
    // along d before scattering, from one light chosen uniformly
    // (weighted by the number of lights). mis = false: for a vertex whose phase-sampled
    // continuation cannot be weighted (a sphere step's events k >= 2), each light's whole
    // direct light from shadow rays alone: a delta light's sample, any other light's
    // sample and a phase-sampled ray, combined by MIS.
    Vec3 direct_light(const Vec3& p, float r, const Vec3& d, int shape, int channel,
                      Rng& rng, bool mis = true) const;
    // Transmittance from p (inside shape `shape`, or -1 for vacuum) along unit w over
    // `dist`, exact from the boundaries one ray crosses (RayTracer::crossings); 0 when a
    // dielectric boundary or an emitter is in the way, or past kMaxShadowCrossings
    // boundaries. With `emitter`, an emitter's quad ends the ray instead of blocking it:
    // the result is the transmittance up to it, and *emitter says which light, how far
    // along w, and its normal (light -1: none met). A ray to infinity that leaves the
    // scene meets the environment, if there is one (t = kInf). `light_in`: the medium the
    // light at `dist` lies inside (Scene::light_medium), whose face the ray may meet at
    // the light itself when the light lies on it: that face does not block it.
    struct EmitterHit {
        int light = -1;
        float t = 0.f;
        Vec3 normal;
    };
    Vec3 transmittance(const Vec3& p, const Vec3& w, float dist, int shape,
                       EmitterHit* emitter = nullptr, int light_in = -1) const;

    const Scene& scene_;
    int max_bounces_;
    bool nee_;
    const SphereTracing* st_;
    std::vector<int> delta_lights_;  // indices of the point and directional lights
    // Per shape: the point lights within its bounds, the only ones a shadow ray from
    // inside can reach in less than the grid's bound (direct_light).
    std::vector<std::vector<int>> near_points_;
};

}  // namespace sss

// The sphere-step policy of integrator "st" (docs/sphere-tracing.md): when and
// how large a sphere step is, and one step sampled and mapped into the world. The path
// logic around it (throughput, NEE weights, MIS state, roulette) is PathTracer's: "st" is
// the path tracer with this policy switched on.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/rng.h"
#include "core/vec.h"
#include "render/scene.h"

namespace sss {

class ScatteringModel;
class CutStepModel;
class CutPlanes;

// Cut sphere steps (integrator "st" with cut_models; docs/sphere-tracing.md, "Cut sphere
// steps"): the ball's radius in mean free paths of the medium's smallest extinction, and
// the least optical depth (same extinction) between a collision and its certified plane
// for a cut step to be taken there. By measurement (bench/README.md, "Cut sphere steps").
constexpr float kCutRadiusMfp = 6.f;
constexpr float kCutMinDepth = 0.5f;

// The largest optical radius of a step when exact walks stand in for the models (the same
// as the models' training range, docs/notation.md).
constexpr float kWalkSigmaMax = 200.f;
// A scene albedo this close outside EventGen's training range of phi is clamped into it
// for EventGen (only the choice of the representative event sees the clamp; the weights
// phi^N and Lambda use the true albedo). Further outside is an error.
constexpr float kPhiClampTolerance = 1e-3f;

// One step in world space.
struct WorldSphereStep {
    int64_t N = 1;  // scattering events the step stands for (>= 1)
    Vec3 exit_pos;  // p + r' x, on the sphere
    Vec3 exit_dir;  // unit travel direction after the exit
    Vec3 X, W;  // representative event and the unit direction arriving at it (with_event)
    bool first_event =
        true;  // the representative event is the first one, at p (X = p, W = w_in)
};

// A sphere step a path waits for (PathTracer::advance): where and how large, and what
// its light connection is weighted with.
struct StepRequest {
    Vec3 p, w_in;        // the sphere's centre and the unit direction entering it
    float radius = 0.f;  // r' in world units
    float sigma = 0.f;   // sigma_t r'
    float g = 0.f,
          phi = 0.f;  // the medium's anisotropy; the albedo EventGen is asked about
    bool with_event = false;  // sample the representative event (NEE)
    Vec3 nee_weight{1.f};     // channel weights of its light connection (before Lambda)
    // A cut sphere step instead (sigma, radius and g as above; never with_event): the
    // plane's unit normal, its distance h in radii and the cosine mu0 of w_in to it.
    bool cut = false;
    Vec3 cut_n{0.f, 0.f, 1.f};
    float cut_h = 1.f, cut_mu0 = 0.f;
};

class SphereTracing {
public:
    // Loads the models from `models` (not for the walks, nor when threshold is infinite:
    // no step can happen) and checks every medium of the scene against their training
    // ranges: g, sigma from max(threshold, lower end) to the upper end, and (with NEE,
    // for media that get NEE) every channel's albedo. A medium outside them takes no
    // steps (it renders as with "pt"), and warnings() names the shape, the value and the
    // range.
    //
    // With `cut_models` (a directory; empty: none) it also loads the cut sphere models
    // and builds plane certificates (geometry/cut_planes.h) for every medium whose steps
    // need neither a representative event (wants_event) nor a clearance (clearance):
    // those media take cut steps (cut_step).
    SphereTracing(const Scene& scene, float threshold, SphereSampler sampler,
                  const std::string& models, bool nee, StepNee step_nee = StepNee::Hits,
                  const std::string& cut_models = "");
    ~SphereTracing();
    SphereTracing(const SphereTracing&) = delete;
    SphereTracing& operator=(const SphereTracing&) = delete;

    float threshold() const { return threshold_; }
    // Whether any medium of the scene has a point deep enough for a step (sigma_t r >=
    // threshold + clearance with r the grid's bound, sigma_t spectral_switch_extinction).
    // When none has, "st" is "pt" exactly, and the renderer traces it as "pt" (no paths
    // in flight).
    bool may_step() const { return may_step_; }
    // Whether `shape` has such a point.
    bool can_step(int shape) const;
    // One line per medium that takes no steps because the models were not trained for
    // it (the constructor's checks).
    const std::vector<std::string>& warnings() const { return warnings_; }
    // Steps are shrunk so that sigma = sigma_t * r' <= sigma_max.
    float sigma_max() const { return sigma_max_; }
    StepNee step_nee() const { return step_nee_; }
    // Whether a step in `shape` samples its representative event: StepNee::Event, NEE on,
    // events that sample lights (Scene::medium_samples_lights: an index-matched boundary
    // or a point light inside; elsewhere a dielectric-bounded medium gets no NEE, as in
    // pt) and any light.
    bool wants_event(int shape) const;
    // The mean free paths a step's ball in `shape` keeps from the boundary and from the
    // point lights: kDeltaLightClearance where its events would need light sampling that
    // the exit flight cannot replace (StepNee::Hits, NEE on, events that sample lights:
    // Scene::medium_samples_lights, a point or directional light), else 0.
    float clearance(int shape) const { return clearance_[size_t(shape)]; }
    // The radius of the ball a step at collision p in `shape` may take, given the grid's
    // bound r at p and the extinction sigma that measures the clearance (the stepping
    // channel's; with spectral MIS spectral_switch_extinction, which decides where the
    // path goes on in one channel): r, or the ball clear of the boundary and the
    // point lights (cleared_step_radius; negative where none fits). A step needs sigma
    // times it >= threshold().
    float step_radius(int shape, Vec3 p, float r, float sigma) const {
        const float c = clearance_[size_t(shape)];
        return c == 0.f ? r : cleared_radius(p, r, sigma, c);
    }
    // The albedo EventGen is asked about for scene albedo phi (clamped into its range).
    float event_phi(float phi) const;
    // The learned models it samples steps from (loaded once, by the constructor); null
    // for exact walks or an infinite threshold.
    const ScatteringModel* model() const { return model_.get(); }

    // One step for request r: its sampler's random numbers from rng, then one for the
    // turn psi about w_in.
    WorldSphereStep sample(const StepRequest& r, Rng& rng) const;
    // `count` steps, step k for *requests[k] with *rngs[k]: the same samples as `count`
    // calls of sample(), faster per step for the learned models (their decoders run on
    // the steps together; model calls of at most kMaxGroup cut steps or
    // ScatteringModel::kMaxGroup sphere steps, more are split).
    // Cut step requests get cut steps (WorldSphereStep's N, exit_pos, exit_dir), the same
    // as sample()'s up to rounding (CutStepModel::sample_group).
    void sample_group(int count, const StepRequest* const* requests, Rng* const* rngs,
                      WorldSphereStep* out) const;
    static constexpr int kMaxGroup = 16;

    // Whether collisions in `shape` may take cut steps (cut_models given, and the shape
    // has plane certificates).
    bool cuts(int shape) const {
        return size_t(shape) < cut_planes_.size() &&
               cut_planes_[size_t(shape)] != nullptr;
    }
    // A cut step's certificate at collision p in `shape` (cuts(shape)): the unit normal n
    // towards the surface and the distance s to the plane along it, if the plane lies at
    // least kCutMinDepth mean free paths (smallest extinction) from p. Depends on p only,
    // not on a path's channel.
    bool cut_certificate(int shape, Vec3 p, Vec3* n, float* s) const;
    // The request of a cut step at collision p (certificate n, s) for a photon that
    // arrived along w_in, with extinction sigma_t (one channel), in `shape`: the ball's
    // radius is the shape's, shrunk so that sigma_t R stays in the models' range. Sets
    // r's geometry and cut fields (the caller sets the rest as for a sphere step).
    void cut_request(int shape, Vec3 p, Vec3 w_in, Vec3 n, float s, float sigma_t,
                     StepRequest* r) const;
    // What cut_certificate and cut_request read, for the GPU's copy
    // (gpu/gpu_scene_bake.h): the loaded cut models (null without cut_models), a shape's
    // certificates (cuts(shape)), its smallest extinction, and the models' largest sigma.
    const CutStepModel* cut_model() const { return cut_model_.get(); }
    const CutPlanes& cut_planes(int shape) const { return *cut_planes_[size_t(shape)]; }
    float cut_sigma_min(int shape) const { return cut_sigma_min_[size_t(shape)]; }
    float cut_sigma_hi() const { return cut_sigma_hi_; }

private:
    void load_models(const std::string& dir);
    void load_cuts(const std::string& dir);
    float cleared_radius(Vec3 p, float r, float sigma, float clearance) const;

    const Scene& scene_;
    float threshold_;
    SphereSampler sampler_;
    bool nee_;
    StepNee step_nee_;
    float sigma_max_ = kWalkSigmaMax;
    bool may_step_ = false;
    std::vector<std::string> warnings_;
    float phi_lo_ = 0.f, phi_hi_ = 1.f;
    std::vector<float> clearance_;   // per shape (clearance())
    std::vector<LightData> points_;  // the delta lights at a finite distance
    std::unique_ptr<ScatteringModel> model_;
    std::unique_ptr<CutStepModel> cut_model_;
    std::vector<std::unique_ptr<CutPlanes>> cut_planes_;  // per shape; null: no cut steps
    std::vector<float> cut_sigma_min_;                    // per shape: min sigma_t
    float cut_sigma_lo_ = 0.f, cut_sigma_hi_ = 0.f, cut_h_lo_ = 0.f;
};

}  // namespace sss

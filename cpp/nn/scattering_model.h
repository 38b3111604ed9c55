// The learned sphere step (docs/sphere-tracing.md, docs/model-format.md): LengthGen,
// PathGen and EventGen loaded from one directory, sampled for an optical radius sigma =
// sigma_t * r, the HG anisotropy g and the single-scattering albedo phi. Everything is in
// the canonical exit frame of docs/notation.md (photon enters at the centre travelling
// +z).
//
// One step, in the order it consumes the Rng (both implementations consume it
// identically):
//   1. xi; if xi < exp(-sigma): N = 1 exactly, cos_theta = hg_sample_cos(xi', g),
//      alpha = beta = 0, X = 0, W = +z (no network, no more random numbers).
//   2. Normals for LengthGen then PathGen (latent z, then output noise eps;
//      sample_normals).
//   3. LengthGen(sigma, g) -> N = max(2, floor(x)) (capped at kMaxScatterCount).
//   4. PathGen(sigma, g, N) -> cos_theta clamped to [-1, 1]; (alpha, beta) scaled to the
//      unit disc if outside it.
//   4'. Only with a tilt (tilt.json, step_tilt.h): one more xi; unless xi <
//      tilt_acceptance(...), steps 2 to 4' again (at most kTiltMaxDraws draws in all;
//      the last is kept).
//   5. Only if EventGen is asked for: its normals, then EventGen(sigma, g, phi, N,
//      cos_theta, alpha, beta) -> X scaled into the unit ball if outside, W normalized
//      (+z if zero); then one more xi: if xi < (1 - phi) / (1 - phi^N) (1/N for
//      phi = 1), the first event (X = 0, W = +z) is the representative one instead
//      (EventGen models events k >= 2). Steps 1 to 4' draw the same numbers with the
//      event or without it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "core/rng.h"
#include "core/vec.h"
#include "nn/decoder.h"
#include "nn/simd_decoder.h"
#include "nn/step_tilt.h"

namespace sss {

// N is an int64; a network that predicts an absurd count is clamped here (phi^N is 0
// anyway).
constexpr int64_t kMaxScatterCount = int64_t(1) << 40;

// One sampled sphere step in the exit frame.
struct SphereStep {
    int64_t N = 1;          // scattering events in the sphere, >= 1
    float cos_theta = 1.f;  // exit point (sin theta, 0, cos theta)
    float alpha = 0.f,
          beta = 0.f;       // exit direction alpha b + beta t + sqrt(1 - a^2 - b^2) n
    Vec3 X{0.f, 0.f, 0.f};  // representative event position, |X| <= 1 (EventGen)
    Vec3 W{0.f, 0.f, 1.f};  // direction arriving at X, unit (EventGen)
};

class ScatteringModel {
public:
    // Loads dir/lengthgen.json, dir/pathgen.json and dir/eventgen.json and checks that
    // each is the decoder it should be (name, conditions and outputs of the table in
    // docs/model-format.md) and that the encodings are defined wherever the step uses
    // them; and dir/tilt.json, PathGen's forward-memory tilt, if the directory has one
    // and `tilt` is true.
    static ScatteringModel load(const std::string& dir, bool tilt = true);
    // The same from three decoders already in memory (tests, tools); `where` names them.
    ScatteringModel(Decoder length, Decoder path, Decoder event,
                    const std::string& where = "");

    // One step. Throws sss::Error if sigma, g (or, with the event, phi) is outside the
    // training ranges of the decoders that the step uses or outside the domain of their
    // encodings. With the SIMD decoder a lone step is slow (it runs on paths in lanes
    // with 15 of 16 lanes idle): callers with many steps use sample_group.
    SphereStep sample(float sigma, float g, float phi, Rng& rng, bool with_event = true,
                      DecoderImpl impl = DecoderImpl::Simd) const;

    // `count` steps at once (at most kMaxGroup), step k with its own parameters and its
    // own Rng: the same samples as `count` calls of `sample`, bit for bit. With the SIMD
    // decoder up to 16 steps are the lanes of one evaluation (SimdDecoder::sample_lanes),
    // and 16 cost about as much as one (bench/README.md); the steps the tilt draws again
    // fill the lanes of later evaluations, so the more steps per call the fewer lanes
    // idle. For a renderer that advances several paths together.
    void sample_group(int count, const float* sigma, const float* g, const float* phi,
                      Rng* rng, bool with_event, DecoderImpl impl, SphereStep* out) const;
    static constexpr int kMaxGroup = 64;

    // n steps for per-sample parameters (arrays of n), sample i drawn with Rng(seed, i):
    // the result does not depend on `threads` (0: all hardware threads). All inputs are
    // checked before any sampling; the message names the first bad index. Runs in groups
    // of kBatchGroup steps.
    void sample_batch(const float* sigma, const float* g, const float* phi, size_t n,
                      uint64_t seed, int threads, bool with_event, DecoderImpl impl,
                      SphereStep* out) const;
    static constexpr int kBatchGroup = 64;

    // PathGen's forward-memory tilt (empty: none; the steps are the decoders' own).
    const StepTilt& tilt() const { return tilt_; }
    void set_tilt(StepTilt tilt) { tilt_ = std::move(tilt); }

    const Decoder& length_gen() const { return length_; }
    const Decoder& path_gen() const { return path_; }
    const Decoder& event_gen() const { return event_; }
    // The decoder called `name` ("LengthGen" or "lengthgen", ...); throws if there is
    // none.
    const Decoder& decoder(const std::string& name) const;
    const SimdDecoder& simd_decoder(const std::string& name) const;
    // The sigma range in which every decoder was trained (the renderer clamps to its
    // upper end).
    Range sigma_range() const;
    const std::string& where() const { return where_; }

    // Throws the error `sample` would throw for these inputs; otherwise returns.
    void check_inputs(float sigma, float g, float phi, bool with_event,
                      const char* index = "") const;

private:
    template <class Ops>
    void group_with(int count, const float* sigma, const float* g, const float* phi,
                    Rng* rng, bool with_event, const Ops& ops, SphereStep* out) const;
    // The quick form of check_inputs: true if the inputs are valid.
    bool inputs_ok(float sigma, float g, float phi, bool with_event) const;

    std::string where_;
    Decoder length_, path_, event_;
    SimdDecoder length_simd_, path_simd_, event_simd_;
    StepTilt tilt_;
    // Precomputed for inputs_ok: [without event, with event] intersections of the
    // training ranges of (sigma, g, phi), and the encodings of those conditions.
    struct Limits {
        double lo[3], hi[3];
        std::vector<std::pair<int, Encoding>>
            encodings;  // (0 sigma | 1 g | 2 phi, encoding)
    } limits_[2];
};

}  // namespace sss

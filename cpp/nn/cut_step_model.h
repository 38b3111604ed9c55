// The learned cut sphere step (docs/notation.md, "The cut sphere problem";
// docs/learning.md, "Learned cut sphere steps"): CutLengthGen and CutPathGen loaded from
// one directory, sampled for an optical radius sigma = sigma_t * R, the HG anisotropy g,
// the plane's distance h (in radii) and the cosine mu0 between the arriving direction and
// the plane's normal. Everything is in the walk's frame: the plane z = h, the medium z <
// h, the photon at the centre having arrived along (sqrt(1 - mu0^2), 0, mu0), about to
// scatter there.
//
// One step, in the order it consumes the Rng:
//   1. u1, u2: the first direction w = hg_sample((sqrt(1 - mu0^2), 0, mu0), g, u1, u2);
//      u3: the flight t = -log1p(-u3) / sigma. With d = h / w.z where w.z > h, else 1
//      (the distance to the region's boundary), t >= d leaves: N = 1, exit at w d,
//      direction w.
//   2. Otherwise the normals of CutLengthGen then CutPathGen, one set (latent z, then
//   output
//      noise eps of each; sample_normals); N = max(2, floor(x)) (capped at
//      kMaxScatterCount), then cos_p, cos_psi (clamped to [-1, 1]) and (alpha, beta)
//      (into the unit disc): the exit point seen from the centre P = (sin_p cos_psi,
//      sin_p sin_psi, cos_p), the exit direction D = alpha t + beta b + sqrt(1 - alpha^2
//      - beta^2) n in cut_exit_frame(P); one more uniform mirrors both in y with
//      probability 1/2.
//   3. The exit point is the region's boundary in direction P (the plane at P h / P.z
//   where
//      P.z > h, else P). D leaves the region there by construction; a D that rounding
//      turned inwards is reflected about the tangent plane.
// The same rules as sssphere.learn.cut.CutSampler (NumPy), which tests compare it with
// (tests/test_cut_model.py, through _core.cut_steps); the encodings run in float on lanes
// (code_lanes), as the sphere step's.
#pragma once

#include <cstdint>
#include <string>

#include "core/rng.h"
#include "core/vec.h"
#include "nn/decoder.h"
#include "nn/simd_decoder.h"
#include "shared/cut_step.h"

namespace sss {

struct CutStep {
    int64_t N = 1;               // scattering events in the region, >= 1
    bool through_plane = false;  // left through the plane z = h (else through the cap)
    Vec3 exit_pos{0.f, 0.f, 1.f};
    Vec3 exit_dir{0.f, 0.f, 1.f};
};

class CutStepModel {
public:
    // Loads dir/cutlengthgen.json and dir/cutpathgen.json and checks that each is the
    // decoder it should be (name, conditions, outputs) with the training ranges of sigma,
    // g, h and mu0.
    static CutStepModel load(const std::string& dir);
    CutStepModel(Decoder length, Decoder path, const std::string& where = "");

    // One step; throws sss::Error for inputs outside the training ranges.
    CutStep sample(float sigma, float g, float h, float mu0, Rng& rng) const;
    // `count` steps (at most SimdDecoder::kLanes), step k with its own inputs and Rng:
    // the same samples as `count` calls of sample, up to float rounding in groups of more
    // than four, whose networks run once for all of them, on paths in lanes
    // (SimdDecoder::sample_lanes; fewer run one after the other, as sample does).
    void sample_group(int count, const float* sigma, const float* g, const float* h,
                      const float* mu0, Rng* rng, CutStep* out) const;
    // Whether sample would accept these inputs.
    bool inputs_ok(float sigma, float g, float h, float mu0) const;
    void check_inputs(float sigma, float g, float h, float mu0) const;

    // The intersection of both decoders' training ranges of `param` (sigma, g, h, mu0).
    Range range(const std::string& param) const;
    const std::string& where() const { return where_; }
    const Decoder& length_gen() const { return length_; }
    const Decoder& path_gen() const { return path_; }

private:
    std::string where_;
    Decoder length_, path_;
    SimdDecoder length_simd_, path_simd_;
    Range ranges_[4];  // sigma, g, h, mu0
};

}  // namespace sss

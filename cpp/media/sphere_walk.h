// The canonical sphere problem (docs/notation.md, "The canonical sphere problem"): ground
// truth for training and evaluating the learned scattering models.
//
// A photon starts at the centre of the unit sphere travelling +z; the first scattering
// event is at the centre and counts. It alternates Henyey-Greenstein scattering and
// exponential free flights with optical radius sigma (= sigma_t * r) until a flight
// leaves the sphere. Absorption is not simulated: N, the exit point and the exit
// direction do not depend on the albedo phi, which only chooses the representative event
// (X, W).
//
// Results are in the exit frame: rotated about z so that the exit point is
// x = (sin theta, 0, cos theta); n = x, b = +y, t = b x n = (cos theta, 0, -sin theta),
// and the exit direction is w = alpha b + beta t + sqrt(1 - alpha^2 - beta^2) n.
#pragma once

#include <cstdint>
#include <vector>

#include "core/rng.h"
#include "core/vec.h"

namespace sss {

struct SphereWalk {
    int64_t N = 1;          // scattering events, >= 1 (the centre counts)
    float cos_theta = 1.f;  // exit point's z
    float alpha = 0.f;      // exit direction . b
    float beta = 0.f;       // exit direction . t
    Vec3 X;                 // representative event position (|X| <= 1), exit frame
    Vec3 W{0.f, 0.f, 1.f};  // direction arriving at X (unit), exit frame
};

// One walk. sigma >= 0 (0: the photon never scatters again), |g| < 1, albedo in [0, 1].
// Event k is the representative one with probability albedo^k / sum_{j<=N} albedo^j.
SphereWalk sphere_walk(float sigma, float g, float albedo, Rng& rng);

// The random stream of walk `index` under `seed`; walks are independent of how they are
// split into batches or threads.
inline Rng sphere_walk_rng(uint64_t seed, uint64_t index) {
    constexpr uint64_t kSphereWalkStream =
        0x5370686572655721ull;  // differs from render streams
    return Rng(seed, index, kSphereWalkStream);
}

struct SphereWalkBatch {
    std::vector<int64_t> N;
    std::vector<float> cos_theta, alpha, beta;
    std::vector<float> X, W;  // n x 3, row-major
};

// Walks first_index .. first_index + n - 1 with per-walk parameters (arrays of length n,
// or of length 1 to broadcast). threads <= 0: all hardware threads. The result is
// identical for any thread count. Throws sss::Error on invalid parameters.
SphereWalkBatch sphere_walks(const std::vector<float>& sigma, const std::vector<float>& g,
                             const std::vector<float>& albedo, int64_t n, uint64_t seed,
                             uint64_t first_index = 0, int threads = 0);

// The cut sphere problem (docs/notation.md, "The cut sphere problem"; issue 26): ground
// truth for a step near a locally flat boundary. The unit sphere is cut by the plane
// z = h (0 < h; h >= 1 leaves it whole) and the medium is the part z < h. The photon
// arrived at the centre travelling w_in = (sqrt(1 - mu0^2), 0, mu0) and scatters there
// (the first event, which counts); it alternates Henyey-Greenstein scattering and
// exponential free flights with optical radius sigma until a flight leaves the region,
// through the plane (the boundary) or through the spherical cap (into more medium).
// With h >= 1 and mu0 = 1 it is sphere_walk's walk, random number for random number, and
// the representative event (X, W) is chosen as there (in the walk's frame, not rotated).
struct CutSphereWalk {
    int64_t N = 1;               // scattering events, >= 1 (the centre counts)
    bool through_plane = false;  // left through z = h (else through the cap)
    Vec3 exit_pos;               // on the plane (z = h, |x| <= 1) or the cap (|x| = 1)
    Vec3 exit_dir;               // unit; leaves the region there
    Vec3 X;                      // representative event (the centre: X = 0, W = w_in)
    Vec3 W;                      // direction arriving at X
};

// One walk. sigma >= 0, |g| < 1, h > 0, |mu0| <= 1, albedo in [0, 1].
CutSphereWalk cut_sphere_walk(float sigma, float g, float h, float mu0, float albedo,
                              Rng& rng);

struct CutSphereWalkBatch {
    std::vector<int64_t> N;
    std::vector<uint8_t> through_plane;
    std::vector<float> exit_pos, exit_dir, X, W;  // n x 3, row-major
};

// Walks first_index .. first_index + n - 1, as sphere_walks (the same streams).
CutSphereWalkBatch cut_sphere_walks(const std::vector<float>& sigma,
                                    const std::vector<float>& g,
                                    const std::vector<float>& h,
                                    const std::vector<float>& mu0,
                                    const std::vector<float>& albedo, int64_t n,
                                    uint64_t seed, uint64_t first_index = 0,
                                    int threads = 0);

}  // namespace sss

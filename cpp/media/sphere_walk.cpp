#include "media/sphere_walk.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"
#include "core/parallel.h"
#include "shared/hg.h"

namespace sss {

namespace {

// Mean N grows as sigma^2 (1 - g) / 2; above this a single walk takes seconds.
constexpr float kMaxSigma = 1000.f;

// A per-walk parameter: one value for all, or one per walk.
float at(const std::vector<float>& v, int64_t i) {
    return v.size() == 1 ? v[0] : v[size_t(i)];
}

// Runs walk(i, rng) for i in [0, n), walk i on its own stream (sphere_walk_rng): walk
// costs differ by orders of magnitude, so in small chunks handed out one at a time.
template <class Walk>
void for_each_walk(int64_t n, uint64_t seed, uint64_t first_index, int threads,
                   const Walk& walk) {
    parallel_chunks(threads, n, 256, [&](int64_t begin, int64_t end) {
        for (int64_t i = begin; i < end; ++i) {
            Rng rng = sphere_walk_rng(seed, first_index + uint64_t(i));
            walk(i, rng);
        }
    });
}

// Rotation about z taking the exit point into the half-plane y = 0, x >= 0.
struct ExitFrameRotation {
    float c = 1.f, s = 0.f;
    explicit ExitFrameRotation(Vec3 x) {
        float rho = std::sqrt(x.x * x.x + x.y * x.y);
        if (rho > 0.f) c = x.x / rho, s = x.y / rho;  // at the poles: the identity
    }
    Vec3 operator()(Vec3 v) const { return {c * v.x + s * v.y, -s * v.x + c * v.y, v.z}; }
};

}  // namespace

SphereWalk sphere_walk(float sigma, float g, float albedo, Rng& rng) {
    Vec3 p(0.f), w(0.f, 0.f, 1.f);
    int64_t n_events = 1;
    SphereWalk out;  // X = 0, W = +z: event 1 is the representative one so far

    // Reservoir over events with weights albedo^k: event k replaces the current choice
    // with probability albedo^k / sum_{j<=k} albedo^j = albedo^(k-1) (1 - albedo) / (1 -
    // albedo^k). Tracked in double as a running power and a running sum of positive terms
    // (no cancellation, no underflow trouble: the probability simply tends to 0).
    const double q = 1.0 - double(albedo);
    double power = 1.0;    // albedo^(k-1)
    double one_minus = q;  // 1 - albedo^k

    for (;;) {
        // Scatter at the current event, then fly.
        float u1 = rng.uniform(), u2 = rng.uniform();
        w = hg_sample(w, g, u1, u2);
        float t = sigma > 0.f ? -std::log1p(-rng.uniform()) / sigma : INFINITY;
        Vec3 next = p + w * t;
        if (!(dot(next, next) < 1.f)) break;  // the flight leaves the sphere
        p = next;
        ++n_events;
        power *= albedo;
        one_minus += power * q;
        double replace = q > 0.0 ? power * q / one_minus : 1.0 / double(n_events);
        if (double(rng.uniform()) < replace) out.X = p, out.W = w;
    }

    // Exit point: p + s w with |p + s w| = 1, s > 0 (|p| < 1, so the root is real).
    float b = dot(p, w), c = dot(p, p) - 1.f;
    float s = -b + std::sqrt(std::max(0.f, b * b - c));
    Vec3 x = normalize(p + w * s);

    ExitFrameRotation rot(x);
    float sin_theta = std::sqrt(x.x * x.x + x.y * x.y);
    Vec3 w_exit = rot(w);
    out.N = n_events;
    out.cos_theta = std::clamp(x.z, -1.f, 1.f);
    out.alpha = w_exit.y;
    out.beta = w_exit.x * out.cos_theta - w_exit.z * sin_theta;
    float tangential = out.alpha * out.alpha + out.beta * out.beta;
    if (n_events == 1) {  // single scattering: the exit direction is exactly x
        out.alpha = out.beta = 0.f;
    } else if (tangential > 1.f) {  // rounding only: w . n >= 0 at the exit
        float k = 1.f / std::sqrt(tangential);
        out.alpha *= k, out.beta *= k;
    }
    out.X = rot(out.X);
    out.W = rot(out.W);
    return out;
}

SphereWalkBatch sphere_walks(const std::vector<float>& sigma, const std::vector<float>& g,
                             const std::vector<float>& albedo, int64_t n, uint64_t seed,
                             uint64_t first_index, int threads) {
    if (n < 0) fail("sphere_walks: n = ", n, " (allowed: n >= 0)");
    auto check_size = [&](const std::vector<float>& v, const char* name) {
        if (v.size() != 1 && int64_t(v.size()) != n)
            fail("sphere_walks: ", name, " has ", v.size(),
                 " values (allowed: 1 or n = ", n, ")");
    };
    check_size(sigma, "sigma_t");
    check_size(g, "g");
    check_size(albedo, "albedo");
    for (size_t i = 0; i < sigma.size(); ++i)
        if (!(sigma[i] >= 0.f && sigma[i] <= kMaxSigma))
            fail("sphere_walks: sigma_t[", i, "] = ", sigma[i],
                 " (allowed: 0 <= sigma_t <= ", kMaxSigma,
                 "; the mean number of events grows as sigma_t^2)");
    for (size_t i = 0; i < g.size(); ++i)
        if (!(std::abs(g[i]) < 1.f))
            fail("sphere_walks: g[", i, "] = ", g[i], " (allowed: -1 < g < 1)");
    for (size_t i = 0; i < albedo.size(); ++i)
        if (!(albedo[i] >= 0.f && albedo[i] <= 1.f))
            fail("sphere_walks: albedo[", i, "] = ", albedo[i],
                 " (allowed: 0 <= albedo <= 1)");

    SphereWalkBatch out;
    out.N.resize(n);
    out.cos_theta.resize(n);
    out.alpha.resize(n);
    out.beta.resize(n);
    out.X.resize(3 * n);
    out.W.resize(3 * n);
    for_each_walk(n, seed, first_index, threads, [&](int64_t i, Rng& rng) {
        SphereWalk w = sphere_walk(at(sigma, i), at(g, i), at(albedo, i), rng);
        out.N[i] = w.N;
        out.cos_theta[i] = w.cos_theta;
        out.alpha[i] = w.alpha;
        out.beta[i] = w.beta;
        for (int k = 0; k < 3; ++k) out.X[3 * i + k] = w.X[k], out.W[3 * i + k] = w.W[k];
    });
    return out;
}

CutSphereWalk cut_sphere_walk(float sigma, float g, float h, float mu0, float albedo,
                              Rng& rng) {
    Vec3 p(0.f), w(std::sqrt(std::max(0.f, 1.f - mu0 * mu0)), 0.f, mu0);
    CutSphereWalk out;
    out.W = w;
    // The representative event: sphere_walk's reservoir.
    const double q = 1.0 - double(albedo);
    double power = 1.0, one_minus = q;
    for (;;) {
        // Scatter at the current event, then fly (sphere_walk's order of random numbers).
        const float u1 = rng.uniform(), u2 = rng.uniform();
        w = hg_sample(w, g, u1, u2);
        const float t = sigma > 0.f ? -std::log1p(-rng.uniform()) / sigma : INFINITY;
        const Vec3 next = p + w * t;
        // The flight leaves the region where it lands outside it (sphere_walk's test for
        // the ball; z >= h implies it for h >= 1). Then: through whichever surface it
        // meets first (the ball's root is real as |p| < 1; the plane only moving up).
        if (!(dot(next, next) < 1.f && next.z < h)) {
            const float b = dot(p, w), c = dot(p, p) - 1.f;
            const float s_ball = -b + std::sqrt(std::max(0.f, b * b - c));
            const float s_plane = w.z > 0.f ? (h - p.z) / w.z : INFINITY;
            const float s_exit = std::min(s_ball, s_plane);
            out.through_plane = s_plane < s_ball;
            out.exit_pos = p + w * s_exit;
            if (out.through_plane)
                out.exit_pos.z = h;
            else
                out.exit_pos = normalize(out.exit_pos);
            out.exit_dir = w;
            return out;
        }
        p = next;
        ++out.N;
        power *= albedo;
        one_minus += power * q;
        const double replace = q > 0.0 ? power * q / one_minus : 1.0 / double(out.N);
        if (double(rng.uniform()) < replace) out.X = p, out.W = w;
    }
}

CutSphereWalkBatch cut_sphere_walks(const std::vector<float>& sigma,
                                    const std::vector<float>& g,
                                    const std::vector<float>& h,
                                    const std::vector<float>& mu0,
                                    const std::vector<float>& albedo, int64_t n,
                                    uint64_t seed, uint64_t first_index, int threads) {
    if (n < 0) fail("cut_sphere_walks: n = ", n, " (allowed: n >= 0)");
    auto check = [&](const std::vector<float>& v, const char* name, auto ok,
                     const char* allowed) {
        if (v.size() != 1 && int64_t(v.size()) != n)
            fail("cut_sphere_walks: ", name, " has ", v.size(),
                 " values (allowed: 1 or n = ", n, ")");
        for (size_t i = 0; i < v.size(); ++i)
            if (!ok(v[i]))
                fail("cut_sphere_walks: ", name, "[", i, "] = ", v[i],
                     " (allowed: ", allowed, ")");
    };
    check(
        sigma, "sigma_t", [](float x) { return x >= 0.f && x <= kMaxSigma; },
        "0 <= sigma_t <= 1000");
    check(
        g, "g", [](float x) { return std::abs(x) < 1.f; }, "-1 < g < 1");
    check(
        h, "h", [](float x) { return x > 0.f && x < INFINITY; }, "h > 0");
    check(
        mu0, "mu0", [](float x) { return std::abs(x) <= 1.f; }, "-1 <= mu0 <= 1");
    check(
        albedo, "albedo", [](float x) { return x >= 0.f && x <= 1.f; },
        "0 <= albedo <= 1");

    CutSphereWalkBatch out;
    out.N.resize(n);
    out.through_plane.resize(n);
    out.exit_pos.resize(3 * n);
    out.exit_dir.resize(3 * n);
    out.X.resize(3 * n);
    out.W.resize(3 * n);
    for_each_walk(n, seed, first_index, threads, [&](int64_t i, Rng& rng) {
        const CutSphereWalk w = cut_sphere_walk(at(sigma, i), at(g, i), at(h, i),
                                                at(mu0, i), at(albedo, i), rng);
        out.N[i] = w.N;
        out.through_plane[i] = w.through_plane ? 1 : 0;
        for (int k = 0; k < 3; ++k) {
            out.exit_pos[3 * i + k] = w.exit_pos[k];
            out.exit_dir[3 * i + k] = w.exit_dir[k];
            out.X[3 * i + k] = w.X[k];
            out.W[3 * i + k] = w.W[k];
        }
    });
    return out;
}

}  // namespace sss

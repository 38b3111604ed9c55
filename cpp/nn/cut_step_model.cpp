#include "nn/cut_step_model.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/check.h"
#include "nn/scattering_model.h"
#include "shared/cut_step.h"
#include "shared/hg.h"
#include "shared/sphere_step.h"

namespace sss {

namespace {

const char* const kConditions[4] = {"sigma", "g", "h", "mu0"};
// Up to this many paths are evaluated one after the other, more in lanes
// (bench/README.md, "Cut sphere steps").
constexpr int kCutLanesFrom = 4;
// Bounds of the buffers: decoder input widths and normals per step.
constexpr int kMaxWidth = 16, kMaxNormals = 32;

void expect(const Decoder& d, const char* name,
            std::initializer_list<const char*> conditions,
            std::initializer_list<const char*> outputs) {
    if (d.name != name)
        fail(d.source, ": holds model '", d.name, "', expected '", name, "'");
    auto names = [](const std::vector<EncodedVariable>& v) {
        std::string s;
        for (const auto& e : v) s += (s.empty() ? "" : ", ") + e.name;
        return s;
    };
    auto want = [](std::initializer_list<const char*> v) {
        std::string s;
        for (const char* e : v) s += (s.empty() ? "" : ", ") + std::string(e);
        return s;
    };
    if (names(d.conditions) != want(conditions))
        fail(d.source, ": ", name, " conditions are [", names(d.conditions),
             "], expected [", want(conditions), "]");
    if (names(d.outputs) != want(outputs))
        fail(d.source, ": ", name, " outputs are [", names(d.outputs), "], expected [",
             want(outputs), "]");
}

float finite_or(float x, float fallback) { return std::isfinite(x) ? x : fallback; }

// SimdDecoder::sample_lanes's contract (x, eps, u in lanes) for `count` paths; a few
// paths run one after the other (sample_encoded, whose cost grows with the count), more
// on all the lanes at once (whose cost does not).
void lanes(const SimdDecoder& d, int width, int outputs, const float* x, const float* eps,
           float* u, int count) {
    constexpr int L = SimdDecoder::kLanes;
    if (count > kCutLanesFrom) return d.sample_lanes(x, eps, u, count);
    alignas(64) float xr[kMaxWidth * L], er[4 * L], ur[4 * L];
    for (int k = 0; k < count; ++k) {
        for (int i = 0; i < width; ++i) xr[k * width + i] = x[i * L + k];
        for (int i = 0; i < outputs; ++i) er[k * outputs + i] = eps[i * L + k];
    }
    d.sample_encoded(xr, er, ur, count);
    for (int k = 0; k < count; ++k)
        for (int i = 0; i < outputs; ++i) u[i * L + k] = ur[k * outputs + i];
}

}  // namespace

CutStepModel CutStepModel::load(const std::string& dir) {
    namespace fs = std::filesystem;
    if (!fs::is_directory(dir))  // as ScatteringModel::load says it
        fail(dir, ": not a directory (expected cutlengthgen.json, cutpathgen.json)");
    Decoder length = load_decoder((fs::path(dir) / "cutlengthgen.json").string());
    Decoder path = load_decoder((fs::path(dir) / "cutpathgen.json").string());
    return CutStepModel(std::move(length), std::move(path), dir);
}

CutStepModel::CutStepModel(Decoder length, Decoder path, const std::string& where)
    : where_(where),
      length_(std::move(length)),
      path_(std::move(path)),
      length_simd_(length_),
      path_simd_(path_) {
    expect(length_, "CutLengthGen", {"sigma", "g", "h", "mu0"}, {"N"});
    expect(path_, "CutPathGen", {"sigma", "g", "h", "mu0", "N"},
           {"cos_p", "cos_psi", "alpha", "beta"});
    for (int i = 0; i < 4; ++i) {
        const Range* a = length_.training_range(kConditions[i]);
        const Range* b = path_.training_range(kConditions[i]);
        if (!a || !b)
            fail(a ? path_.source : length_.source, ": training has no range of '",
                 kConditions[i], "'");
        ranges_[i] = Range{std::max(a->lo, b->lo), std::min(a->hi, b->hi)};
    }
    for (int i = 0; i < 4; ++i)
        for (double x : {ranges_[i].lo, ranges_[i].hi})
            if (!length_.conditions[i].encoding.in_domain(float(x)) ||
                !path_.conditions[i].encoding.in_domain(float(x)))
                fail(where_, ": the training range of '", kConditions[i],
                     "' leaves the domain of its encoding");
}

Range CutStepModel::range(const std::string& param) const {
    for (int i = 0; i < 4; ++i)
        if (param == kConditions[i]) return ranges_[i];
    fail("CutStepModel::range: no condition '", param, "' (allowed: sigma, g, h, mu0)");
}

bool CutStepModel::inputs_ok(float sigma, float g, float h, float mu0) const {
    const float v[4] = {sigma, g, h, mu0};
    for (int i = 0; i < 4; ++i)
        if (!ranges_[i].contains(v[i])) return false;  // NaN fails too
    return true;
}

void CutStepModel::check_inputs(float sigma, float g, float h, float mu0) const {
    const float v[4] = {sigma, g, h, mu0};
    for (int i = 0; i < 4; ++i)
        if (!ranges_[i].contains(v[i]))
            fail("cut step: ", kConditions[i], " = ", v[i],
                 " is outside the training range [", ranges_[i].lo, ", ", ranges_[i].hi,
                 "] of the cut models in ", where_);
}

CutStep CutStepModel::sample(float sigma, float g, float h, float mu0, Rng& rng) const {
    CutStep out;
    sample_group(1, &sigma, &g, &h, &mu0, &rng, &out);
    return out;
}

void CutStepModel::sample_group(int count, const float* sigma, const float* g,
                                const float* h, const float* mu0, Rng* rng,
                                CutStep* out) const {
    constexpr int L = SimdDecoder::kLanes;
    if (count < 0 || count > L)
        fail("cut sample_group: count ", count, " is not in [0, ", L, "]");
    for (int k = 0; k < count; ++k) check_inputs(sigma[k], g[k], h[k], mu0[k]);
    const int nl = length_.latent_dim, np = path_.latent_dim;
    const int n_normals = nl + 1 + np + 4;
    SSS_CHECK(n_normals <= kMaxNormals && length_.input_width <= kMaxWidth &&
              path_.input_width <= kMaxWidth);
    // 1. Every path's first flight, exactly; the others' normals.
    Vec3 P[L], D[L];
    int net[L], m = 0;
    float z[L][kMaxNormals];
    for (int k = 0; k < count; ++k) {
        out[k] = CutStep();
        const Vec3 w_in(std::sqrt(std::max(0.f, 1.f - mu0[k] * mu0[k])), 0.f, mu0[k]);
        const float u1 = rng[k].uniform(), u2 = rng[k].uniform();
        const Vec3 w = hg_sample(w_in, g[k], u1, u2);
        const float t = -std::log1p(-rng[k].uniform()) / sigma[k];
        const float d = cut_first_exit(w, h[k]);
        P[k] = D[k] = w;
        if (!(t >= d)) {
            sample_normals(rng[k], z[m], n_normals, DecoderImpl::Simd);
            net[m++] = k;
        }
    }
    if (m > 0) {
        // 2. The networks on the paths in lanes: x[i * L + j] is input i of lane j. The
        // encodings and decodings run on the lanes too, in float (code_lanes, as the
        // sphere step's). Lanes from m on hold valid values too (the kernels may read
        // whole vectors): copies of lane 0's, N = 2, u = 0.
        alignas(64) float x[kMaxWidth * L] = {0.f}, eps[4 * L] = {0.f}, u[4 * L] = {0.f};
        // code_lanes and the kernels load whole aligned vectors.
        alignas(64) float raw[4][L], n_lanes[L], dec[4][L];
        for (int j = 0; j < L; ++j) {
            const int k = net[j < m ? j : 0];
            raw[0][j] = sigma[k], raw[1][j] = g[k], raw[2][j] = h[k], raw[3][j] = mu0[k];
            n_lanes[j] = 2.f;
        }
        for (int i = 0; i < 4; ++i)
            code_lanes(length_.conditions[i].encoding, false, raw[i], x + i * L, m,
                       DecoderImpl::Simd);
        for (int j = 0; j < m; ++j) {
            for (int i = 0; i < nl; ++i) x[(4 + i) * L + j] = z[j][i];
            eps[j] = z[j][nl];
        }
        lanes(length_simd_, length_.input_width, 1, x, eps, u, m);
        for (int j = 0; j < m; ++j) u[j] = finite_or(u[j], 0.f);
        code_lanes(length_.outputs[0].encoding, true, u, dec[0], m, DecoderImpl::Simd);
        std::fill(x, x + kMaxWidth * L, 0.f);
        for (int j = 0; j < m; ++j) {
            const float n_raw = finite_or(dec[0][j], 2.f);
            out[net[j]].N = int64_t(
                std::clamp(std::floor(double(n_raw)), 2.0, double(kMaxScatterCount)));
            n_lanes[j] = float(out[net[j]].N);
        }
        for (int i = 0; i < 4; ++i)
            code_lanes(path_.conditions[i].encoding, false, raw[i], x + i * L, m,
                       DecoderImpl::Simd);
        code_lanes(path_.conditions[4].encoding, false, n_lanes, x + 4 * L, m,
                   DecoderImpl::Simd);
        for (int j = 0; j < m; ++j) {
            for (int i = 0; i < np; ++i) x[(5 + i) * L + j] = z[j][nl + 1 + i];
            for (int i = 0; i < 4; ++i) eps[i * L + j] = z[j][nl + 1 + np + i];
        }
        lanes(path_simd_, path_.input_width, 4, x, eps, u, m);
        for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < m; ++j) u[i * L + j] = finite_or(u[i * L + j], 0.f);
            code_lanes(path_.outputs[i].encoding, true, u + i * L, dec[i], m,
                       DecoderImpl::Simd);
        }
        for (int j = 0; j < m; ++j) {
            const int k = net[j];
            const float cos_p = std::clamp(finite_or(dec[0][j], 1.f), -1.f, 1.f);
            const float cos_psi = std::clamp(finite_or(dec[1][j], 1.f), -1.f, 1.f);
            float alpha = finite_or(dec[2][j], 0.f), beta = finite_or(dec[3][j], 0.f);
            project_into_disc(alpha, beta);
            cut_network_exit(cos_p, cos_psi, alpha, beta, h[k], P[k], D[k]);
            if (rng[k].uniform() < 0.5f) {  // the mirror image in y (the networks' half)
                P[k].y = -P[k].y;
                D[k].y = -D[k].y;
            }
        }
    }
    // 3. The exit point in direction P and the direction made to leave there.
    for (int k = 0; k < count; ++k) {
        const CutExit e = cut_exit(P[k], D[k], h[k]);
        out[k].through_plane = e.through_plane;
        out[k].exit_pos = e.pos;
        out[k].exit_dir = e.dir;
    }
}

}  // namespace sss

#include "nn/scattering_model.h"

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <cmath>
#include <exception>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

#include "core/check.h"
#include "shared/hg.h"

namespace sss {

namespace {

// Inputs and noise vectors of the step live on the stack; Table 1 needs at most 12
// and 11.
constexpr int kMaxStepWidth = 32;

struct Expected {
    const char* name;
    std::vector<const char*> conditions, outputs;
};
const Expected kLength{"LengthGen", {"sigma", "g"}, {"N"}};
const Expected kPath{"PathGen", {"sigma", "g", "N"}, {"cos_theta", "alpha", "beta"}};
const Expected kEvent{"EventGen",
                      {"sigma", "g", "phi", "N", "cos_theta", "alpha", "beta"},
                      {"X_x", "X_y", "X_z", "W_x", "W_y", "W_z"}};

std::string join(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
    return s;
}

void check_decoder(const Decoder& d, const Expected& e) {
    if (d.name != e.name)
        fail(d.source, ": name \"", d.name, "\" where ", e.name, " was expected");
    auto names = [](const std::vector<EncodedVariable>& vars) {
        std::vector<std::string> n;
        for (const auto& v : vars) n.push_back(v.name);
        return n;
    };
    std::vector<std::string> want_c(e.conditions.begin(), e.conditions.end());
    std::vector<std::string> want_o(e.outputs.begin(), e.outputs.end());
    if (names(d.conditions) != want_c)
        fail(d.source, ": conditions [", join(names(d.conditions)), "] where ", e.name,
             " has [", join(want_c), "] (in this order; docs/model-format.md)");
    if (names(d.outputs) != want_o)
        fail(d.source, ": outputs [", join(names(d.outputs)), "] where ", e.name,
             " has [", join(want_o), "] (in this order; docs/model-format.md)");
    if (d.input_width > kMaxStepWidth || d.latent_dim + d.num_outputs() > kMaxStepWidth)
        fail(d.source, ": input_width ", d.input_width, " and latent_dim ", d.latent_dim,
             " are larger than the sphere step supports (", kMaxStepWidth, ")");
}

// A condition computed inside the step (N, cos_theta, alpha, beta) must be encodable for
// every value the step can produce: N in [2, inf), the others in [-1, 1].
void check_internal_domain(const Decoder& d, const std::string& name, float lo,
                           bool unbounded_above, float hi) {
    for (const auto& c : d.conditions) {
        if (c.name != name) continue;
        const Encoding& e = c.encoding;
        bool ok = e.in_domain(lo) &&
                  (unbounded_above ? e.kind == Encoding::Kind::Affine ||
                                         (e.kind == Encoding::Kind::Log && e.s > 0.f)
                                   : e.in_domain(hi));
        if (!ok)
            fail(d.source, ": conditions: the encoding of '", name, "' (s = ", e.s,
                 ", c = ", e.c, ") is undefined for some ", name, " in [", lo, ", ",
                 unbounded_above ? "inf" : std::to_string(hi),
                 "], values the sphere step produces");
    }
}

bool iequals(const std::string& a, const std::string& b) {
    return a.size() == b.size() &&
           std::equal(a.begin(), a.end(), b.begin(),
                      [](char x, char y) { return std::tolower(x) == std::tolower(y); });
}

// The two evaluators behind one interface: Box-Muller on `lanes` lanes and
// u = mean + exp(logvar / 2) eps for `count` inputs of one decoder.
struct ScalarOps {
    void box_muller(const float* xr, const float* xa, float* c, float* s,
                    int lanes) const {
        sss::box_muller(xr, xa, c, s, lanes, DecoderImpl::Scalar);
    }
    void sample(const Decoder& d, const SimdDecoder&, int count, const float* x,
                const float* eps, float* u) const {
        const int n = d.num_outputs();
        float mean[kMaxStepWidth], logvar[kMaxStepWidth];
        for (int k = 0; k < count; ++k) {
            evaluate_reference(d, x + k * d.input_width, mean, logvar);
            for (int i = 0; i < n; ++i)
                u[k * n + i] = mean[i] + std::exp(0.5f * logvar[i]) * eps[k * n + i];
        }
    }
};

struct SimdOps {
    void box_muller(const float* xr, const float* xa, float* c, float* s,
                    int lanes) const {
        sss::box_muller(xr, xa, c, s, lanes, DecoderImpl::Simd);
    }
    void sample(const Decoder&, const SimdDecoder& sd, int count, const float* x,
                const float* eps, float* u) const {
        sd.sample_encoded(x, eps, u, count);
    }
};

// A network output made finite before post-processing: NaN -> 0, +-inf -> +-FLT_MAX. Only
// a broken model produces either, but the step must still return a valid sample.
inline float finite(float x) {
    if (std::isnan(x)) return 0.f;
    return std::clamp(x, -FLT_MAX, FLT_MAX);
}

// Fills x with [encoded conditions, z, 0...] for decoder d (input_width entries).
inline void make_input(const Decoder& d, const float* values, const float* z, float* x) {
    int nc = d.num_conditions();
    for (int i = 0; i < nc; ++i) x[i] = d.conditions[i].encoding.encode(values[i]);
    std::copy(z, z + d.latent_dim, x + nc);
    std::fill(x + nc + d.latent_dim, x + d.input_width, 0.f);
}

}  // namespace

ScatteringModel::ScatteringModel(Decoder length, Decoder path, Decoder event,
                                 const std::string& where)
    : where_(where),
      length_(std::move(length)),
      path_(std::move(path)),
      event_(std::move(event)),
      length_simd_(length_),
      path_simd_(path_),
      event_simd_(event_) {
    check_decoder(length_, kLength);
    check_decoder(path_, kPath);
    check_decoder(event_, kEvent);
    check_internal_domain(path_, "N", 2.f, true, 0.f);
    check_internal_domain(event_, "N", 2.f, true, 0.f);
    for (const char* v : {"cos_theta", "alpha", "beta"})
        check_internal_domain(event_, v, -1.f, false, 1.f);

    const char* params[3] = {"sigma", "g", "phi"};
    for (int with_event = 0; with_event < 2; ++with_event) {
        Limits& lim = limits_[with_event];
        lim.lo[0] = 0.0, lim.hi[0] = INFINITY;  // sigma >= 0
        lim.lo[1] = -1.0, lim.hi[1] = 1.0;      // |g| < 1 (strict: checked apart)
        lim.lo[2] = 0.0, lim.hi[2] = 1.0;       // phi in [0, 1]
        for (const Decoder* d : {&length_, &path_, with_event ? &event_ : nullptr}) {
            if (!d) continue;
            for (const auto& c : d->conditions) {
                for (int p = 0; p < 3; ++p) {
                    if (c.name != params[p]) continue;
                    const Range* r = d->training_range(params[p]);
                    lim.lo[p] = std::max(lim.lo[p], r->lo);
                    lim.hi[p] = std::min(lim.hi[p], r->hi);
                    lim.encodings.emplace_back(p, c.encoding);
                }
            }
        }
    }
}

ScatteringModel ScatteringModel::load(const std::string& dir) {
    namespace fs = std::filesystem;
    if (!fs::is_directory(dir))
        fail(dir,
             ": not a directory (expected lengthgen.json, pathgen.json, eventgen.json)");
    auto file = [&](const char* name) { return (fs::path(dir) / name).string(); };
    return ScatteringModel(load_decoder(file("lengthgen.json")),
                           load_decoder(file("pathgen.json")),
                           load_decoder(file("eventgen.json")), dir);
}

const Decoder& ScatteringModel::decoder(const std::string& name) const {
    for (const Decoder* d : {&length_, &path_, &event_})
        if (iequals(name, d->name)) return *d;
    fail("no decoder named '", name, "' (allowed: LengthGen, PathGen, EventGen)");
}

const SimdDecoder& ScatteringModel::simd_decoder(const std::string& name) const {
    const Decoder& d = decoder(name);
    return &d == &length_ ? length_simd_ : &d == &path_ ? path_simd_ : event_simd_;
}

Range ScatteringModel::sigma_range() const {
    Range r{-INFINITY, INFINITY};
    for (const Decoder* d : {&length_, &path_, &event_}) {
        const Range* s = d->training_range("sigma");
        r.lo = std::max(r.lo, s->lo);
        r.hi = std::min(r.hi, s->hi);
    }
    return r;
}

bool ScatteringModel::inputs_ok(float sigma, float g, float phi, bool with_event) const {
    const Limits& lim = limits_[with_event];
    const double v[3] = {sigma, g, phi};
    for (int p = 0; p < 3; ++p)
        if (!(v[p] >= lim.lo[p] && v[p] <= lim.hi[p])) return false;  // NaN fails too
    if (!std::isfinite(sigma) || !(std::abs(g) < 1.f)) return false;
    for (const auto& [p, e] : lim.encodings)
        if (!e.in_domain(float(v[p]))) return false;
    return true;
}

void ScatteringModel::check_inputs(float sigma, float g, float phi, bool with_event,
                                   const char* index) const {
    if (inputs_ok(sigma, g, phi, with_event)) return;
    if (!(sigma >= 0.f) || !std::isfinite(sigma))
        fail("sigma", index, " = ", sigma, " is not allowed (allowed: sigma >= 0)");
    if (!(std::abs(g) < 1.f))
        fail("g", index, " = ", g, " is not allowed (allowed: -1 < g < 1)");
    if (!(phi >= 0.f && phi <= 1.f))
        fail("phi", index, " = ", phi, " is not allowed (allowed: 0 <= phi <= 1)");
    const Decoder* used[3] = {&length_, &path_, with_event ? &event_ : nullptr};
    const float values[3] = {sigma, g, phi};
    const char* names[3] = {"sigma", "g", "phi"};
    for (const Decoder* d : used) {
        if (!d) continue;
        for (int p = 0; p < 3; ++p) {
            for (const auto& c : d->conditions) {
                if (c.name != names[p]) continue;
                const Range* r = d->training_range(names[p]);
                if (!r->contains(values[p]))
                    fail(names[p], index, " = ", values[p],
                         " is outside the training range [", r->lo, ", ", r->hi, "] of ",
                         d->name, " (", d->source, ")",
                         p == 0 ? "; the renderer shrinks the sphere to stay within it"
                                : "");
                if (!c.encoding.in_domain(values[p]))
                    fail(names[p], index, " = ", values[p],
                         " is outside the domain of its encoding in ", d->name, " (",
                         d->source, ")");
            }
        }
    }
}

template <class Ops>
void ScatteringModel::group_with(int K, const float* sigma, const float* g,
                                 const float* phi, Rng* rng, bool with_event,
                                 const Ops& ops, SphereStep* out) const {
    // N = 1 exactly with probability e^{-sigma}: the photon leaves along its first HG
    // direction.
    int act[kMaxGroup], na = 0;
    for (int k = 0; k < K; ++k) {
        out[k] = SphereStep();
        if (rng[k].uniform() < std::exp(-sigma[k]))
            out[k].cos_theta = hg_sample_cos(rng[k].uniform(), g[k]);
        else
            act[na++] = k;
    }
    if (na == 0) return;

    // The normals of every step that needs the networks, in one Box-Muller call: per
    // step, those of LengthGen and PathGen (z, eps, z, eps), then EventGen's (z, eps) if
    // asked for.
    const Decoder &L = length_, &P = path_, &E = event_;
    const int n_lp = L.latent_dim + 1 + P.latent_dim + 3,
              n_e = with_event ? E.latent_dim + 6 : 0;
    const int lanes_lp = normal_lanes(n_lp),
              lanes = lanes_lp + (n_e ? normal_lanes(n_e) : 0);
    constexpr int kMaxLanes = 3 * kMaxStepWidth;
    float xr[kMaxGroup * kMaxLanes], xa[kMaxGroup * kMaxLanes], c[kMaxGroup * kMaxLanes],
        sn[kMaxGroup * kMaxLanes];
    for (int j = 0; j < na; ++j) {
        draw_normal_uniforms(rng[act[j]], n_lp, xr + j * lanes, xa + j * lanes);
        if (n_e)
            draw_normal_uniforms(rng[act[j]], n_e, xr + j * lanes + lanes_lp,
                                 xa + j * lanes + lanes_lp);
    }
    ops.box_muller(xr, xa, c, sn, na * lanes);
    float z[kMaxGroup][3 * kMaxStepWidth];
    for (int j = 0; j < na; ++j) {
        assemble_normals(c + j * lanes, sn + j * lanes, n_lp, z[j]);
        if (n_e)
            assemble_normals(c + j * lanes + lanes_lp, sn + j * lanes + lanes_lp, n_e,
                             z[j] + n_lp);
    }

    float x[kMaxGroup * kMaxStepWidth], eps[kMaxGroup * kMaxStepWidth],
        u[kMaxGroup * kMaxStepWidth];
    // LengthGen(sigma, g) -> N = max(2, floor(x))
    for (int j = 0; j < na; ++j) {
        const float cond[2] = {sigma[act[j]], g[act[j]]};
        make_input(L, cond, z[j], x + j * L.input_width);
        eps[j] = z[j][L.latent_dim];
    }
    ops.sample(L, length_simd_, na, x, eps, u);
    for (int j = 0; j < na; ++j) {
        float n_real = L.outputs[0].encoding.decode(u[j]);
        out[act[j]].N =
            n_real >= 2.f
                ? (n_real < float(kMaxScatterCount) ? int64_t(n_real) : kMaxScatterCount)
                : 2;
    }

    // PathGen(sigma, g, N) -> cos_theta clamped, (alpha, beta) into the unit disc
    const int zp = L.latent_dim + 1;
    for (int j = 0; j < na; ++j) {
        const int k = act[j];
        const float cond[3] = {sigma[k], g[k], float(out[k].N)};
        make_input(P, cond, z[j] + zp, x + j * P.input_width);
        std::copy(z[j] + zp + P.latent_dim, z[j] + zp + P.latent_dim + 3, eps + 3 * j);
    }
    ops.sample(P, path_simd_, na, x, eps, u);
    for (int j = 0; j < na; ++j) {
        SphereStep& s = out[act[j]];
        const float* uj = u + 3 * j;
        s.cos_theta = std::clamp(finite(P.outputs[0].encoding.decode(uj[0])), -1.f, 1.f);
        float a = finite(P.outputs[1].encoding.decode(uj[1])),
              b = finite(P.outputs[2].encoding.decode(uj[2]));
        double r2 = double(a) * a + double(b) * b;  // no overflow in double
        if (r2 > 1.0) {
            double f = 1.0 / std::sqrt(r2);
            a = float(a * f);
            b = float(b * f);
            while (a * a + b * b > 1.f) {  // rounding
                a *= 0.99999994f;
                b *= 0.99999994f;
            }
        }
        s.alpha = a;
        s.beta = b;
    }
    if (!with_event) return;

    // EventGen(sigma, g, phi, N, cos_theta, alpha, beta) -> X into the unit ball, W unit
    for (int j = 0; j < na; ++j) {
        const int k = act[j];
        const SphereStep& s = out[k];
        const float cond[7] = {sigma[k],    g[k],    phi[k], float(s.N),
                               s.cos_theta, s.alpha, s.beta};
        make_input(E, cond, z[j] + n_lp, x + j * E.input_width);
        std::copy(z[j] + n_lp + E.latent_dim, z[j] + n_lp + E.latent_dim + 6,
                  eps + 6 * j);
    }
    ops.sample(E, event_simd_, na, x, eps, u);
    for (int j = 0; j < na; ++j) {
        SphereStep& s = out[act[j]];
        float v[6];
        for (int i = 0; i < 6; ++i)
            v[i] = finite(E.outputs[i].encoding.decode(u[6 * j + i]));
        Vec3 X{v[0], v[1], v[2]}, W{v[3], v[4], v[5]};
        double x2 = double(X.x) * X.x + double(X.y) * X.y + double(X.z) * X.z;
        if (x2 > 1.0) {
            double f = 1.0 / std::sqrt(x2);
            X = {float(X.x * f), float(X.y * f), float(X.z * f)};
            while (dot(X, X) > 1.f) X *= 0.99999994f;  // rounding
        }
        double w2 = double(W.x) * W.x + double(W.y) * W.y + double(W.z) * W.z;
        if (w2 > 0.0) {
            double f = 1.0 / std::sqrt(w2);
            W = {float(W.x * f), float(W.y * f), float(W.z * f)};
        } else {
            W = {0.f, 0.f, 1.f};
        }
        s.X = X;
        s.W = W;
        // The first event (the centre) is the representative one with the exact
        // probability phi / sum_{j<=N} phi^j = (1 - phi) / (1 - phi^N) (1/N for phi = 1);
        // EventGen models only events k >= 2 (docs/model-format.md).
        const double p = phi[act[j]], n = double(s.N);
        const double p_first =
            p >= 1.0 ? 1.0 / n : (1.0 - p) / -std::expm1(n * std::log(p));
        if (double(rng[act[j]].uniform()) < p_first) {
            s.X = Vec3(0.f);
            s.W = Vec3(0.f, 0.f, 1.f);
        }
    }
}

SphereStep ScatteringModel::sample(float sigma, float g, float phi, Rng& rng,
                                   bool with_event, DecoderImpl impl) const {
    check_inputs(sigma, g, phi, with_event);
    SphereStep s;
    if (impl == DecoderImpl::Simd)
        group_with(1, &sigma, &g, &phi, &rng, with_event, SimdOps(), &s);
    else
        group_with(1, &sigma, &g, &phi, &rng, with_event, ScalarOps(), &s);
    return s;
}

void ScatteringModel::sample_group(int count, const float* sigma, const float* g,
                                   const float* phi, Rng* rng, bool with_event,
                                   DecoderImpl impl, SphereStep* out) const {
    if (count < 0 || count > kMaxGroup)
        fail("sample_group: count ", count, " is not in [0, ", kMaxGroup, "]");
    for (int k = 0; k < count; ++k) {
        if (inputs_ok(sigma[k], g[k], phi[k], with_event)) continue;
        std::string index = "[" + std::to_string(k) + "]";
        check_inputs(sigma[k], g[k], phi[k], with_event, index.c_str());
    }
    if (impl == DecoderImpl::Simd)
        group_with(count, sigma, g, phi, rng, with_event, SimdOps(), out);
    else
        group_with(count, sigma, g, phi, rng, with_event, ScalarOps(), out);
}

void ScatteringModel::sample_batch(const float* sigma, const float* g, const float* phi,
                                   size_t n, uint64_t seed, int threads, bool with_event,
                                   DecoderImpl impl, SphereStep* out) const {
    for (size_t i = 0; i < n; ++i) {
        if (inputs_ok(sigma[i], g[i], phi[i], with_event)) continue;
        std::string index = "[" + std::to_string(i) + "]";
        check_inputs(sigma[i], g[i], phi[i], with_event, index.c_str());
    }
    auto run = [&](size_t begin, size_t end) {
        Rng rng[kBatchGroup];
        for (size_t i = begin; i < end; i += kBatchGroup) {
            int K = int(std::min<size_t>(kBatchGroup, end - i));
            for (int k = 0; k < K; ++k) rng[k] = Rng(seed, i + k);
            if (impl == DecoderImpl::Simd)
                group_with(K, sigma + i, g + i, phi + i, rng, with_event, SimdOps(),
                           out + i);
            else
                group_with(K, sigma + i, g + i, phi + i, rng, with_event, ScalarOps(),
                           out + i);
        }
    };
    size_t T =
        threads > 0 ? size_t(threads) : std::max(1u, std::thread::hardware_concurrency());
    T = std::max<size_t>(
        1, std::min(T, (n + 255) / 256));  // at least 256 samples per thread
    if (T == 1) {
        run(0, n);
        return;
    }
    std::vector<std::thread> pool;
    std::exception_ptr error;
    std::mutex error_mutex;
    size_t chunk = (n + T - 1) / T;
    for (size_t t = 0; t < T; ++t) {
        size_t begin = t * chunk, end = std::min(n, begin + chunk);
        if (begin >= end) break;
        pool.emplace_back([&, begin, end] {
            try {
                run(begin, end);
            } catch (...) {
                std::lock_guard<std::mutex> lock(error_mutex);
                if (!error) error = std::current_exception();
            }
        });
    }
    for (auto& th : pool) th.join();
    if (error) std::rethrow_exception(error);
}

}  // namespace sss

#include "nn/scattering_model.h"

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <cmath>
#include <filesystem>
#include <vector>

#include "core/check.h"
#include "core/parallel.h"
#include "shared/hg.h"
#include "shared/sphere_step.h"

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

// The two evaluators behind one interface, on paths in lanes (rows of kLanes floats, one
// per variable; SimdDecoder::sample_lanes): Box-Muller on `lanes` lanes,
// u = mean + exp(logvar / 2) eps for the first `count` paths, and an encoding or its
// inverse.
constexpr int kLanes = SimdDecoder::kLanes;

struct ScalarOps {
    static constexpr DecoderImpl kImpl = DecoderImpl::Scalar;
    void box_muller(const float* xr, const float* xa, float* c, float* s,
                    int lanes) const {
        sss::box_muller(xr, xa, c, s, lanes, kImpl);
    }
    void sample(const Decoder& d, const SimdDecoder&, const float* x, const float* eps,
                float* u, int count) const {
        const int n = d.num_outputs();
        float xk[kMaxStepWidth], mean[kMaxStepWidth], logvar[kMaxStepWidth];
        for (int k = 0; k < count; ++k) {
            for (int i = 0; i < d.input_width; ++i) xk[i] = x[i * kLanes + k];
            evaluate_reference(d, xk, mean, logvar);
            for (int i = 0; i < n; ++i)
                u[i * kLanes + k] =
                    mean[i] + std::exp(0.5f * logvar[i]) * eps[i * kLanes + k];
        }
    }
};

struct SimdOps {
    static constexpr DecoderImpl kImpl = DecoderImpl::Simd;
    void box_muller(const float* xr, const float* xa, float* c, float* s,
                    int lanes) const {
        sss::box_muller(xr, xa, c, s, lanes, kImpl);
    }
    void sample(const Decoder&, const SimdDecoder& sd, const float* x, const float* eps,
                float* u, int count) const {
        sd.sample_lanes(x, eps, u, count);
    }
};

// A network output made finite before post-processing: NaN -> 0, +-inf -> +-FLT_MAX. Only
// a broken model produces either, but the step must still return a valid sample.
inline float finite(float x) {
    if (std::isnan(x)) return 0.f;
    return std::clamp(x, -FLT_MAX, FLT_MAX);
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

ScatteringModel ScatteringModel::load(const std::string& dir, bool tilt) {
    namespace fs = std::filesystem;
    if (!fs::is_directory(dir))
        fail(dir,
             ": not a directory (expected lengthgen.json, pathgen.json, eventgen.json)");
    auto file = [&](const char* name) { return (fs::path(dir) / name).string(); };
    ScatteringModel m(load_decoder(file("lengthgen.json")),
                      load_decoder(file("pathgen.json")),
                      load_decoder(file("eventgen.json")), dir);
    std::error_code ec;
    if (tilt && fs::exists(file("tilt.json"), ec))
        m.set_tilt(load_step_tilt(file("tilt.json")));
    return m;
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
    constexpr DecoderImpl impl = Ops::kImpl;
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

    const Decoder &L = length_, &P = path_, &E = event_;
    const int n_lp = L.latent_dim + 1 + P.latent_dim + 3,
              n_e = with_event ? E.latent_dim + 6 : 0;
    float s_act[kMaxGroup], g_act[kMaxGroup], v_act[kMaxGroup];
    for (int j = 0; j < na; ++j) s_act[j] = sigma[act[j]], g_act[j] = g[act[j]];

    // The decoders run on up to kLanes steps at once ("paths in lanes"): row i of x is
    // input i of the steps evaluated together, lane q being step act[sel[q]] for q < ns;
    // lanes past ns repeat lane 0, so that every lane a vector computes holds finite
    // values.
    alignas(64) float x[kMaxStepWidth * kLanes], eps[kMaxStepWidth * kLanes],
        u[kMaxStepWidth * kLanes], raw[kLanes];
    int sel[kLanes], ns = 0;
    auto fill = [&](float* row, auto&& value) {
        for (int q = 0; q < ns; ++q) row[q] = value(sel[q]);
        std::fill(row + ns, row + kLanes, row[0]);
    };
    // Per active step j its normals z[j]: LengthGen's and PathGen's (z, eps, z, eps),
    // then EventGen's (z, eps) if asked for (drawn once the step is kept).
    float z[kMaxGroup][3 * kMaxStepWidth];
    // Condition i of decoder d from raw values, the latent z (from offset zo of each
    // step's normals) and eps (the no outputs after it), zero rows up to input_width.
    auto inputs = [&](const Decoder& d, std::initializer_list<const float*> values,
                      int zo) {
        int i = 0;
        for (const float* v : values) {
            fill(raw, [&](int j) { return v[j]; });
            code_lanes(d.conditions[i].encoding, false, raw, x + i * kLanes, ns, impl);
            std::fill(x + i * kLanes + ns, x + (i + 1) * kLanes, x[i * kLanes]);
            ++i;
        }
        for (int l = 0; l < d.latent_dim; ++l, ++i)
            fill(x + i * kLanes, [&](int j) { return z[j][zo + l]; });
        std::fill(x + i * kLanes, x + d.input_width * kLanes, 0.f);
        for (int o = 0; o < d.num_outputs(); ++o)
            fill(eps + o * kLanes, [&](int j) { return z[j][zo + d.latent_dim + o]; });
    };
    // Output o of decoder d, decoded, into raw (lanes [0, ns)).
    auto output = [&](const Decoder& d, int o) {
        code_lanes(d.outputs[o].encoding, true, u + o * kLanes, raw, ns, impl);
    };

    // The normals of the steps in sel, in one Box-Muller call: `n` of them from offset
    // zo of each step's normals.
    constexpr int kMaxLanes = 3 * kMaxStepWidth;
    float xr[kLanes * kMaxLanes], xa[kLanes * kMaxLanes], c[kLanes * kMaxLanes],
        sn[kLanes * kMaxLanes];
    auto draw_normals = [&](int n, int zo) {
        const int lanes = normal_lanes(n);
        for (int q = 0; q < ns; ++q)
            draw_normal_uniforms(rng[act[sel[q]]], n, xr + q * lanes, xa + q * lanes);
        ops.box_muller(xr, xa, c, sn, ns * lanes);
        for (int q = 0; q < ns; ++q)
            assemble_normals(c + q * lanes, sn + q * lanes, n, z[sel[q]] + zo);
    };

    auto length_and_path = [&] {
        // LengthGen(sigma, g) -> N = max(2, floor(x))
        inputs(L, {s_act, g_act}, 0);
        ops.sample(L, length_simd_, x, eps, u, ns);
        output(L, 0);
        for (int q = 0; q < ns; ++q) {
            const float n_real = raw[q];
            const int j = sel[q];
            out[act[j]].N = n_real >= 2.f
                                ? (n_real < float(kMaxScatterCount) ? int64_t(n_real)
                                                                    : kMaxScatterCount)
                                : 2;
            v_act[j] = float(out[act[j]].N);
        }

        // PathGen(sigma, g, N) -> cos_theta clamped, (alpha, beta) into the unit disc
        inputs(P, {s_act, g_act, v_act}, L.latent_dim + 1);
        ops.sample(P, path_simd_, x, eps, u, ns);
        float ab[3][kLanes];
        for (int o = 0; o < 3; ++o) {
            output(P, o);
            std::copy(raw, raw + ns, ab[o]);
        }
        for (int q = 0; q < ns; ++q) {
            SphereStep& s = out[act[sel[q]]];
            s.cos_theta = std::clamp(finite(ab[0][q]), -1.f, 1.f);
            float a = finite(ab[1][q]), b = finite(ab[2][q]);
            project_into_disc(a, b);  // shared/sphere_step.h
            s.alpha = a;
            s.beta = b;
        }
    };

    // LengthGen and PathGen for every active step, kLanes at a time from a queue. With
    // the forward-memory tilt each drawn step is kept with probability tilt_acceptance
    // (shared/sphere_step.h) and a refused one joins the queue's end to be drawn again
    // (at most kTiltMaxDraws draws, the last kept), so that the draws again fill the
    // lanes of the next evaluations. Each step draws from its own stream, in the order
    // of sample(), whatever the queue does.
    float ta[kMaxGroup], tb[kMaxGroup];
    for (int j = 0; j < na; ++j) tilt_.at(s_act[j], g_act[j], &ta[j], &tb[j]);
    int queue[kMaxGroup], head = 0, waiting = na;  // a ring of step indices j
    int draws[kMaxGroup] = {};
    for (int j = 0; j < na; ++j) queue[j] = j;
    while (waiting > 0) {
        ns = std::min(waiting, kLanes);
        for (int q = 0; q < ns; ++q) sel[q] = queue[(head + q) % kMaxGroup];
        head += ns, waiting -= ns;
        draw_normals(n_lp, 0);
        for (int q = 0; q < ns; ++q) ++draws[sel[q]];
        length_and_path();
        if (tilt_.empty()) continue;
        for (int q = 0; q < ns; ++q) {
            const int j = sel[q];
            const SphereStep& s = out[act[j]];
            const bool kept = rng[act[j]].uniform() <
                              tilt_acceptance(s.cos_theta, s.alpha, s.beta, ta[j], tb[j]);
            if (!kept && draws[j] < kTiltMaxDraws)
                queue[(head + waiting++) % kMaxGroup] = j;
        }
    }
    if (!with_event) return;

    // EventGen(sigma, g, phi, N, cos_theta, alpha, beta) -> X into the unit ball, W unit
    float p_act[kMaxGroup], ct[kMaxGroup], al[kMaxGroup], be[kMaxGroup];
    for (int j = 0; j < na; ++j) {
        const SphereStep& s = out[act[j]];
        p_act[j] = phi[act[j]], ct[j] = s.cos_theta, al[j] = s.alpha, be[j] = s.beta;
    }
    for (int first = 0; first < na; first += kLanes) {
        ns = std::min(na - first, kLanes);
        for (int q = 0; q < ns; ++q) sel[q] = first + q;
        draw_normals(n_e, n_lp);
        inputs(E, {s_act, g_act, p_act, v_act, ct, al, be}, n_lp);
        ops.sample(E, event_simd_, x, eps, u, ns);
        float xw[6][kLanes];
        for (int o = 0; o < 6; ++o) {
            output(E, o);
            std::copy(raw, raw + ns, xw[o]);
        }
        for (int q = 0; q < ns; ++q) {
            const int j = sel[q];
            SphereStep& s = out[act[j]];
            float v[6];
            for (int i = 0; i < 6; ++i) v[i] = finite(xw[i][q]);
            s.X = project_into_ball(Vec3(v[0], v[1], v[2]));  // shared/sphere_step.h
            s.W = unit_or_z(Vec3(v[3], v[4], v[5]));
            // The first event (the centre) is the representative one with its exact
            // probability; EventGen models only events k >= 2.
            if (double(rng[act[j]].uniform()) <
                first_event_probability(phi[act[j]], double(s.N))) {
                s.X = Vec3(0.f);
                s.W = Vec3(0.f, 0.f, 1.f);
            }
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
    // Chunks of 256 samples (whole groups), whatever the thread count
    parallel_chunks(threads, int64_t(n), 256,
                    [&](int64_t begin, int64_t end) { run(size_t(begin), size_t(end)); });
}

}  // namespace sss

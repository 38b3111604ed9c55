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

// Inputs and noise vectors of the step live on the stack; Table 1 needs at most 12 and 11.
constexpr int kMaxStepWidth = 64;

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
    if (d.name != e.name) fail(d.source, ": name \"", d.name, "\" where ", e.name, " was expected");
    auto names = [](const std::vector<EncodedVariable>& vars) {
        std::vector<std::string> n;
        for (const auto& v : vars) n.push_back(v.name);
        return n;
    };
    std::vector<std::string> want_c(e.conditions.begin(), e.conditions.end());
    std::vector<std::string> want_o(e.outputs.begin(), e.outputs.end());
    if (names(d.conditions) != want_c)
        fail(d.source, ": conditions [", join(names(d.conditions)), "] where ", e.name, " has [", join(want_c),
             "] (in this order; docs/model-format.md)");
    if (names(d.outputs) != want_o)
        fail(d.source, ": outputs [", join(names(d.outputs)), "] where ", e.name, " has [", join(want_o),
             "] (in this order; docs/model-format.md)");
    if (d.input_width > kMaxStepWidth || d.latent_dim + d.num_outputs() > kMaxStepWidth)
        fail(d.source, ": input_width ", d.input_width, " and latent_dim ", d.latent_dim,
             " are larger than the sphere step supports (", kMaxStepWidth, ")");
}

// A condition computed inside the step (N, cos_theta, alpha, beta) must be encodable for every
// value the step can produce: N in [2, inf), the others in [-1, 1].
void check_internal_domain(const Decoder& d, const std::string& name, float lo, bool unbounded_above, float hi) {
    for (const auto& c : d.conditions) {
        if (c.name != name) continue;
        const Encoding& e = c.encoding;
        bool ok = e.in_domain(lo) && (unbounded_above ? e.kind == Encoding::Kind::Affine || e.s > 0.f : e.in_domain(hi));
        if (!ok)
            fail(d.source, ": conditions: the encoding of '", name, "' (s = ", e.s, ", c = ", e.c,
                 ") is undefined for some ", name, " in [", lo, ", ", unbounded_above ? "inf" : std::to_string(hi),
                 "], values the sphere step produces");
    }
}

bool iequals(const std::string& a, const std::string& b) {
    return a.size() == b.size() &&
           std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) { return std::tolower(x) == std::tolower(y); });
}

// Scalar reference evaluation of u = mean + exp(logvar / 2) eps.
struct ScalarOps {
    void normals(Rng& rng, float* z, int n) const { sample_normals(rng, z, n, DecoderImpl::Scalar); }
    void sample(const Decoder& d, const SimdDecoder&, const float* x, const float* eps, float* u) const {
        float mean[kMaxStepWidth], logvar[kMaxStepWidth];
        evaluate_reference(d, x, mean, logvar);
        for (int i = 0; i < d.num_outputs(); ++i) u[i] = mean[i] + std::exp(0.5f * logvar[i]) * eps[i];
    }
};

struct SimdOps {
    void normals(Rng& rng, float* z, int n) const { sample_normals(rng, z, n, DecoderImpl::Simd); }
    void sample(const Decoder&, const SimdDecoder& s, const float* x, const float* eps, float* u) const {
        s.sample_encoded(x, eps, u);
    }
};

// A network output made finite before post-processing: NaN -> 0, +-inf -> +-FLT_MAX. Only a
// broken model produces either, but the step must still return a valid sample.
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

ScatteringModel::ScatteringModel(Decoder length, Decoder path, Decoder event, const std::string& where)
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
    for (const char* v : {"cos_theta", "alpha", "beta"}) check_internal_domain(event_, v, -1.f, false, 1.f);
}

ScatteringModel ScatteringModel::load(const std::string& dir) {
    namespace fs = std::filesystem;
    if (!fs::is_directory(dir)) fail(dir, ": not a directory (expected lengthgen.json, pathgen.json, eventgen.json)");
    auto file = [&](const char* name) { return (fs::path(dir) / name).string(); };
    return ScatteringModel(load_decoder(file("lengthgen.json")), load_decoder(file("pathgen.json")),
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

void ScatteringModel::check_inputs(float sigma, float g, float phi, bool with_event, const char* index) const {
    if (!(sigma >= 0.f) || !std::isfinite(sigma)) fail("sigma", index, " = ", sigma, " is not allowed (allowed: sigma >= 0)");
    if (!(std::abs(g) < 1.f)) fail("g", index, " = ", g, " is not allowed (allowed: -1 < g < 1)");
    if (!(phi >= 0.f && phi <= 1.f)) fail("phi", index, " = ", phi, " is not allowed (allowed: 0 <= phi <= 1)");
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
                    fail(names[p], index, " = ", values[p], " is outside the training range [", r->lo, ", ", r->hi,
                         "] of ", d->name, " (", d->source, ")",
                         p == 0 ? "; the renderer shrinks the sphere to stay within it" : "");
                if (!c.encoding.in_domain(values[p]))
                    fail(names[p], index, " = ", values[p], " is outside the domain of its encoding in ", d->name,
                         " (", d->source, ")");
            }
        }
    }
}

template <class Ops>
SphereStep ScatteringModel::sample_with(float sigma, float g, float phi, Rng& rng, bool with_event,
                                        const Ops& ops) const {
    SphereStep s;
    // N = 1 exactly with probability e^{-sigma}: the photon leaves along its first HG direction.
    if (rng.uniform() < std::exp(-sigma)) {
        s.cos_theta = hg_sample_cos(rng.uniform(), g);
        return s;
    }
    float z[2 * kMaxStepWidth], x[kMaxStepWidth], u[kMaxStepWidth];
    const int nl = length_.latent_dim + 1;
    ops.normals(rng, z, nl + path_.latent_dim + 3);

    // LengthGen(sigma, g) -> N
    const float c_length[2] = {sigma, g};
    make_input(length_, c_length, z, x);
    ops.sample(length_, length_simd_, x, z + length_.latent_dim, u);
    float n_real = length_.outputs[0].encoding.decode(u[0]);
    s.N = n_real >= 2.f ? (n_real < float(kMaxScatterCount) ? int64_t(n_real) : kMaxScatterCount) : 2;

    // PathGen(sigma, g, N) -> (cos_theta, alpha, beta)
    const float c_path[3] = {sigma, g, float(s.N)};
    make_input(path_, c_path, z + nl, x);
    ops.sample(path_, path_simd_, x, z + nl + path_.latent_dim, u);
    s.cos_theta = std::clamp(finite(path_.outputs[0].encoding.decode(u[0])), -1.f, 1.f);
    float a = finite(path_.outputs[1].encoding.decode(u[1])), b = finite(path_.outputs[2].encoding.decode(u[2]));
    double r2 = double(a) * a + double(b) * b;  // no overflow in double
    if (r2 > 1.0) {
        double k = 1.0 / std::sqrt(r2);
        a = float(a * k);
        b = float(b * k);
        while (a * a + b * b > 1.f) {  // rounding
            a *= 0.99999994f;
            b *= 0.99999994f;
        }
    }
    s.alpha = a;
    s.beta = b;
    if (!with_event) return s;

    // EventGen(sigma, g, phi, N, cos_theta, alpha, beta) -> (X, W)
    ops.normals(rng, z, event_.latent_dim + 6);
    const float c_event[7] = {sigma, g, phi, float(s.N), s.cos_theta, s.alpha, s.beta};
    make_input(event_, c_event, z, x);
    ops.sample(event_, event_simd_, x, z + event_.latent_dim, u);
    float v[6];
    for (int i = 0; i < 6; ++i) v[i] = finite(event_.outputs[i].encoding.decode(u[i]));
    Vec3 X{v[0], v[1], v[2]}, W{v[3], v[4], v[5]};
    double x2 = double(X.x) * X.x + double(X.y) * X.y + double(X.z) * X.z;
    if (x2 > 1.0) {
        double k = 1.0 / std::sqrt(x2);
        X = {float(X.x * k), float(X.y * k), float(X.z * k)};
        while (dot(X, X) > 1.f) X *= 0.99999994f;  // rounding
    }
    double w2 = double(W.x) * W.x + double(W.y) * W.y + double(W.z) * W.z;
    if (w2 > 0.0) {
        double k = 1.0 / std::sqrt(w2);
        W = {float(W.x * k), float(W.y * k), float(W.z * k)};
    } else {
        W = {0.f, 0.f, 1.f};
    }
    s.X = X;
    s.W = W;
    return s;
}

SphereStep ScatteringModel::sample(float sigma, float g, float phi, Rng& rng, bool with_event,
                                   DecoderImpl impl) const {
    check_inputs(sigma, g, phi, with_event);
    return impl == DecoderImpl::Simd ? sample_with(sigma, g, phi, rng, with_event, SimdOps())
                                     : sample_with(sigma, g, phi, rng, with_event, ScalarOps());
}

void ScatteringModel::sample_batch(const float* sigma, const float* g, const float* phi, size_t n, uint64_t seed,
                                   int threads, bool with_event, DecoderImpl impl, SphereStep* out) const {
    for (size_t i = 0; i < n; ++i) {
        try {
            check_inputs(sigma[i], g[i], phi[i], with_event);
        } catch (const Error&) {  // again, with the index in the message
            std::string index = "[" + std::to_string(i) + "]";
            check_inputs(sigma[i], g[i], phi[i], with_event, index.c_str());
        }
    }
    auto run = [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            Rng rng(seed, i);
            out[i] = impl == DecoderImpl::Simd ? sample_with(sigma[i], g[i], phi[i], rng, with_event, SimdOps())
                                               : sample_with(sigma[i], g[i], phi[i], rng, with_event, ScalarOps());
        }
    };
    size_t T = threads > 0 ? size_t(threads) : std::max(1u, std::thread::hardware_concurrency());
    T = std::max<size_t>(1, std::min(T, (n + 255) / 256));  // at least 256 samples per thread
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

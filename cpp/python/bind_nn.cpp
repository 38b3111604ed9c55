// _core.ScatteringModel: the learned sphere step (cpp/nn/scattering_model.h), numpy in
// and out. The Python API is python/sssphere/model.py, which checks and broadcasts the
// arguments.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <memory>
#include <sstream>

#include "core/check.h"
#include "nn/cut_step_model.h"
#include "nn/scattering_model.h"
#include "python/released_gil.h"

namespace py = pybind11;
using namespace sss;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

std::vector<float> per_sample(const FloatArray& a, const char* name, size_t n) {
    if (a.ndim() != 1 || size_t(a.shape(0)) != n)
        fail(name, " must have shape (", n, ",), got ndim ", a.ndim(),
             a.ndim() == 1 ? " length " + std::to_string(a.shape(0)) : "");
    return std::vector<float>(a.data(), a.data() + n);
}

DecoderImpl parse_impl(const std::string& impl) {
    if (impl == "scalar") return DecoderImpl::Scalar;
    if (impl == "simd") return DecoderImpl::Simd;
    fail("impl '", impl, "' is not allowed (allowed: \"scalar\", \"simd\")");
}

py::dict sample_py(const ScatteringModel& m, const FloatArray& sigma, const FloatArray& g,
                   const FloatArray& albedo, int64_t n, uint64_t seed, int threads,
                   bool event, const std::string& impl) {
    if (n < 1) fail("n must be >= 1, got ", n);
    std::vector<float> s = per_sample(sigma, "sigma", size_t(n)),
                       gg = per_sample(g, "g", size_t(n)),
                       phi = per_sample(albedo, "albedo", size_t(n));
    DecoderImpl which = parse_impl(impl);
    std::vector<SphereStep> out(n);
    {
        ReleasedGil release;
        m.sample_batch(s.data(), gg.data(), phi.data(), size_t(n), seed, threads, event,
                       which, out.data());
    }
    py::array_t<int64_t> N(n);
    py::array_t<float> cos_theta(n), alpha(n), beta(n),
        X({py::ssize_t(n), py::ssize_t(3)}), W({py::ssize_t(n), py::ssize_t(3)});
    auto pN = N.mutable_unchecked<1>();
    auto pc = cos_theta.mutable_unchecked<1>(), pa = alpha.mutable_unchecked<1>(),
         pb = beta.mutable_unchecked<1>();
    auto pX = X.mutable_unchecked<2>(), pW = W.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < n; ++i) {
        const SphereStep& st = out[i];
        pN(i) = st.N;
        pc(i) = st.cos_theta;
        pa(i) = st.alpha;
        pb(i) = st.beta;
        for (int k = 0; k < 3; ++k) {
            pX(i, k) = st.X[k];
            pW(i, k) = st.W[k];
        }
    }
    py::dict d;
    d["N"] = N;
    d["cos_theta"] = cos_theta;
    d["alpha"] = alpha;
    d["beta"] = beta;
    d["X"] = X;
    d["W"] = W;
    return d;
}

py::tuple evaluate_py(const ScatteringModel& m, const std::string& name,
                      const FloatArray& x, const std::string& impl) {
    const Decoder& d = m.decoder(name);
    DecoderImpl which = parse_impl(impl);
    if (x.ndim() != 2 || x.shape(1) != d.input_width)
        fail("x must have shape (batch, ", d.input_width, ") for ", d.name, ", got ndim ",
             x.ndim(), x.ndim() == 2 ? " width " + std::to_string(x.shape(1)) : "");
    py::ssize_t batch = x.shape(0), no = d.num_outputs();
    py::array_t<float> mean({batch, no}), logvar({batch, no});
    const float* px = x.data();
    float *pm = mean.mutable_data(), *pl = logvar.mutable_data();
    const SimdDecoder& s = m.simd_decoder(name);
    {
        ReleasedGil release;
        if (which == DecoderImpl::Simd) {
            for (py::ssize_t k = 0; k < batch; k += 16) {  // 16 inputs per call
                int count = int(std::min<py::ssize_t>(16, batch - k));
                s.evaluate(px + k * d.input_width, pm + k * no, pl + k * no, count);
            }
        } else {
            for (py::ssize_t k = 0; k < batch; ++k)
                evaluate_reference(d, px + k * d.input_width, pm + k * no, pl + k * no);
        }
    }
    return py::make_tuple(mean, logvar);
}

}  // namespace

void bind_nn(py::module_& m) {
    m.def(
        "cut_steps",
        [](const std::string& models, float sigma, float g, float h, float mu0, int64_t n,
           uint64_t seed) {
            if (n < 1) sss::fail("cut_steps: n must be >= 1, got ", n);
            const sss::CutStepModel model = sss::CutStepModel::load(models);
            std::vector<int64_t> N(size_t(n), 0);
            std::vector<uint8_t> plane(size_t(n), 0);
            std::vector<float> pos(size_t(n) * 3), dir(size_t(n) * 3);
            {
                ReleasedGil release;
                constexpr int L = sss::SimdDecoder::kLanes;
                float s[L], gg[L], hh[L], m0[L];
                std::fill(s, s + L, sigma), std::fill(gg, gg + L, g);
                std::fill(hh, hh + L, h), std::fill(m0, m0 + L, mu0);
                for (int64_t i = 0; i < n; i += L) {
                    const int K = int(std::min<int64_t>(L, n - i));
                    sss::Rng rng[L];
                    for (int k = 0; k < K; ++k) rng[k] = sss::Rng(seed, uint64_t(i + k));
                    sss::CutStep out[L];
                    model.sample_group(K, s, gg, hh, m0, rng, out);
                    for (int k = 0; k < K; ++k) {
                        const size_t r = size_t(i + k);
                        N[r] = out[k].N;
                        plane[r] = out[k].through_plane;
                        for (int a = 0; a < 3; ++a) {
                            pos[3 * r + a] = out[k].exit_pos[a];
                            dir[3 * r + a] = out[k].exit_dir[a];
                        }
                    }
                }
            }
            py::dict d;
            auto arr = [](auto&& v, std::vector<py::ssize_t> shape) {
                using T = typename std::decay_t<decltype(v)>::value_type;
                py::array_t<T> a(shape);
                std::copy(v.begin(), v.end(), a.mutable_data());
                return a;
            };
            d["N"] = arr(N, {n});
            d["through_plane"] = arr(plane, {n});
            d["exit_pos"] = arr(pos, {n, 3});
            d["exit_dir"] = arr(dir, {n, 3});
            return d;
        },
        py::arg("models"), py::arg("sigma"), py::arg("g"), py::arg("h"), py::arg("mu0"),
        py::arg("n"), py::arg("seed") = 0,
        "n cut sphere steps from the C++ sampler (nn/cut_step_model.h) with the models "
        "in "
        "`models`, in groups of 16, step i with Rng(seed, i): for tests against the "
        "NumPy "
        "sampler.");
    py::class_<ScatteringModel, std::shared_ptr<ScatteringModel>>(m, "ScatteringModel")
        .def_static(
            "load",
            [](const std::string& path, bool tilt) {
                return std::make_shared<ScatteringModel>(
                    ScatteringModel::load(path, tilt));
            },
            py::arg("path"), py::arg("tilt") = true,
            "Loads lengthgen.json, pathgen.json and eventgen.json from a directory, and "
            "tilt.json (PathGen's forward-memory tilt) if it has one and tilt is true.")
        .def_property_readonly("tilted",
                               [](const ScatteringModel& m) { return !m.tilt().empty(); })
        .def("sample", &sample_py, py::arg("sigma"), py::arg("g"), py::arg("albedo"),
             py::arg("n"), py::arg("seed"), py::arg("threads") = 0,
             py::arg("event") = true, py::arg("impl") = "simd",
             "n sphere steps for per-sample float32 arrays sigma, g, albedo (length n); "
             "sample i uses the "
             "random stream (seed, i). Returns a dict of numpy arrays N, cos_theta, "
             "alpha, beta, X (n, 3), W (n, 3).")
        .def("evaluate", &evaluate_py, py::arg("model_name"), py::arg("x"),
             py::arg("impl") = "simd",
             "(mean, logvar), each (batch, outputs), of decoder model_name for x (batch, "
             "input_width) float32.")
        .def("input_width",
             [](const ScatteringModel& m, const std::string& name) {
                 return m.decoder(name).input_width;
             })
        .def("training_range",
             [](const ScatteringModel& m, const std::string& name,
                const std::string& param) -> py::object {
                 const Range* r = m.decoder(name).training_range(param);
                 if (!r) return py::none();
                 return py::make_tuple(r->lo, r->hi);
             })
        .def_property_readonly("sigma_range",
                               [](const ScatteringModel& m) {
                                   Range r = m.sigma_range();
                                   return py::make_tuple(r.lo, r.hi);
                               })
        .def_property_readonly("path", &ScatteringModel::where)
        .def_property_readonly_static(
            "simd_target", [](py::object) { return std::string(simd_target_name()); })
        .def_static("simd_targets", &simd_targets,
                    "The SIMD targets compiled in that this CPU runs, best first.")
        .def_static("simd_default_target", &simd_default_target,
                    "The SIMD target the decoders run on unless pinned: the best here, "
                    "except AVX2 on Intel's family 6, model 85.")
        .def_static("use_simd_target", &simd_use_target, py::arg("name"),
                    "Pin the decoders' SIMD target ('' = the default here); for "
                    "benchmarks, between renders only.")
        .def("__repr__", [](const ScatteringModel& m) {
            std::ostringstream os;
            Range r = m.sigma_range();
            os << "<sssphere.ScatteringModel '" << m.where()
               << "': LengthGen, PathGen, EventGen; sigma in [" << r.lo << ", " << r.hi
               << "]; SIMD target " << simd_target_name() << ">";
            return os.str();
        });
}

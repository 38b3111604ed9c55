// Bindings of media/: the canonical and the cut sphere walks (numpy in, numpy out).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <vector>

#include "media/sphere_walk.h"
#include "python/released_gil.h"

namespace py = pybind11;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

std::vector<float> to_vector(const FloatArray& a) {
    return std::vector<float>(a.data(), a.data() + a.size());
}

template <typename T>
py::array_t<T> to_array(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
    py::array_t<T> a(shape);
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
}

}  // namespace

void bind_media(py::module_& m) {
    m.def(
        "sphere_walks",
        [](const FloatArray& sigma, const FloatArray& g, const FloatArray& albedo,
           int64_t n, uint64_t seed, uint64_t first_index, int threads) {
            std::vector<float> s = to_vector(sigma), gg = to_vector(g),
                               a = to_vector(albedo);
            sss::SphereWalkBatch b;
            {
                sss::ReleasedGil release;
                b = sss::sphere_walks(s, gg, a, n, seed, first_index, threads);
            }
            py::dict d;
            d["N"] = to_array(std::move(b.N), {n});
            d["cos_theta"] = to_array(std::move(b.cos_theta), {n});
            d["alpha"] = to_array(std::move(b.alpha), {n});
            d["beta"] = to_array(std::move(b.beta), {n});
            d["X"] = to_array(std::move(b.X), {n, 3});
            d["W"] = to_array(std::move(b.W), {n, 3});
            return d;
        },
        py::arg("sigma_t"), py::arg("g"), py::arg("albedo"), py::arg("n"),
        py::arg("seed") = 0, py::arg("first_index") = 0, py::arg("threads") = 0,
        "Canonical unit-sphere walks (see media/sphere_walk.h); parameters are float32 "
        "arrays "
        "of length 1 or n.");
    m.def(
        "cut_sphere_walks",
        [](const FloatArray& sigma, const FloatArray& g, const FloatArray& h,
           const FloatArray& mu0, const FloatArray& albedo, int64_t n, uint64_t seed,
           uint64_t first_index, int threads) {
            std::vector<float> s = to_vector(sigma), gg = to_vector(g), hh = to_vector(h),
                               m0 = to_vector(mu0), a = to_vector(albedo);
            sss::CutSphereWalkBatch b;
            {
                sss::ReleasedGil release;
                b = sss::cut_sphere_walks(s, gg, hh, m0, a, n, seed, first_index,
                                          threads);
            }
            py::dict d;
            d["N"] = to_array(std::move(b.N), {n});
            d["through_plane"] = to_array(std::move(b.through_plane), {n});
            d["exit_pos"] = to_array(std::move(b.exit_pos), {n, 3});
            d["exit_dir"] = to_array(std::move(b.exit_dir), {n, 3});
            d["X"] = to_array(std::move(b.X), {n, 3});
            d["W"] = to_array(std::move(b.W), {n, 3});
            return d;
        },
        py::arg("sigma_t"), py::arg("g"), py::arg("h"), py::arg("mu0"), py::arg("albedo"),
        py::arg("n"), py::arg("seed") = 0, py::arg("first_index") = 0,
        py::arg("threads") = 0,
        "Walks in the unit sphere cut by the plane z = h (see media/sphere_walk.h); "
        "parameters are float32 arrays of length 1 or n.");
}

// The GPU path (cpp/gpu/) for Python: render on a Vulkan device, bake a scene for
// `sssphere-gpu-bench`, and the shader parts the tests compare with the CPU's. Without
// Vulkan in the build (SSSPHERE_HAVE_VULKAN unset), gpu_status() says so and the rest
// throw.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <functional>
#include <optional>

#include "core/check.h"
#include "python/released_gil.h"
#include "python/render_progress.h"
#include "render/scene.h"

#ifdef SSSPHERE_HAVE_VULKAN
#include "gpu/gpu_renderer.h"
#include "gpu/gpu_scene_bake.h"
#include "nn/cut_step_model.h"
#include "nn/scattering_model.h"
#endif

namespace py = pybind11;
using namespace sss;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

#ifdef SSSPHERE_HAVE_VULKAN

#endif

#ifndef SSSPHERE_HAVE_VULKAN
[[noreturn]] void no_vulkan() {
    fail(
        "this build of sssphere has no GPU path (built without Vulkan: install "
        "libvulkan-dev and glslc, then reinstall)");
}
#endif

}  // namespace

void bind_gpu(py::module_& m) {
    m.def("gpu_status", []() -> py::tuple {
#ifdef SSSPHERE_HAVE_VULKAN
        try {
            VulkanCompute vk;
            return py::make_tuple(true, vk.device_name(), vk.is_software());
        } catch (const GpuUnavailable& e) {
            return py::make_tuple(false, std::string(e.what()), false);
        }
#else
        return py::make_tuple(false, std::string("built without Vulkan"), false);
#endif
    });
#ifdef SSSPHERE_HAVE_VULKAN
    m.def(
        "bake_gpu_scene",
        [](const Scene& scene, const std::string& path, const std::string& integrator,
           bool nee, float sphere_threshold, const std::string& models,
           const std::string& cut_models) {
            save_gpu_scene(bake_gpu_scene(scene, integrator, nee, sphere_threshold,
                                          models, cut_models),
                           path);
        },
        py::arg("scene"), py::arg("path"), py::arg("integrator"), py::arg("nee"),
        py::arg("sphere_threshold"), py::arg("models"), py::arg("cut_models") = "");
    m.def(
        "gpu_sample_steps",
        [](const std::string& models, FloatArray sigma, FloatArray g, uint64_t seed,
           std::optional<FloatArray> phi) {
            if (sigma.ndim() != 1 || g.ndim() != 1 || sigma.size() != g.size())
                fail("sigma and g must be 1-d arrays of one length");
            if (phi && (phi->ndim() != 1 || phi->size() != sigma.size()))
                fail("phi must be a 1-d array as long as sigma");
            std::vector<float> packed = pack_gpu_model(ScatteringModel::load(models));
            std::vector<float> out;
            {
                ReleasedGil release;
                VulkanCompute vk;
                out = gpu_sample_steps(vk, packed, sigma.data(), g.data(),
                                       phi ? phi->data() : nullptr, size_t(sigma.size()),
                                       seed, phi.has_value());
            }
            return to_array(out, {py::ssize_t(sigma.size()), 12});
        },
        py::arg("models"), py::arg("sigma"), py::arg("g"), py::arg("seed"),
        py::arg("phi") = py::none(),
        "Sphere steps on the GPU: per step (N, cos_theta, alpha, beta, X, 0, W, 0); with "
        "phi (the albedos), EventGen's representative event X, W too.");
    m.def(
        "gpu_sample_cut_steps",
        [](const std::string& models, FloatArray sigma, FloatArray g, FloatArray h,
           FloatArray mu0, uint64_t seed) {
            for (const FloatArray* a : {&g, &h, &mu0})
                if (sigma.ndim() != 1 || a->ndim() != 1 || a->size() != sigma.size())
                    fail("sigma, g, h and mu0 must be 1-d arrays of one length");
            const CutStepModel model = CutStepModel::load(models);
            for (py::ssize_t i = 0; i < sigma.size(); ++i)
                model.check_inputs(sigma.data()[i], g.data()[i], h.data()[i],
                                   mu0.data()[i]);
            std::vector<float> packed = pack_gpu_cut_model(model);
            std::vector<float> out;
            {
                ReleasedGil release;
                VulkanCompute vk;
                out = gpu_sample_cut_steps(vk, packed, sigma.data(), g.data(), h.data(),
                                           mu0.data(), size_t(sigma.size()), seed);
            }
            return to_array(out, {py::ssize_t(sigma.size()), 12});
        },
        py::arg("models"), py::arg("sigma"), py::arg("g"), py::arg("h"), py::arg("mu0"),
        py::arg("seed"),
        "Cut sphere steps on the GPU: per step (N, through_plane, 0, 0, exit_pos, 0, "
        "exit_dir, 0) in the walk's frame.");
    m.def(
        "gpu_trace_rays",
        [](const Scene& scene, FloatArray origins, FloatArray directions, float tfar) {
            if (origins.ndim() != 2 || origins.shape(1) != 3 || directions.ndim() != 2 ||
                directions.shape(1) != 3 || origins.shape(0) != directions.shape(0))
                fail("origins and directions must have shape (n, 3)");
            const size_t n = size_t(origins.shape(0));
            std::vector<float> rays(8 * n);
            for (size_t i = 0; i < n; ++i) {
                // Origins in the scene file's coordinates, moved into the render frame
                const float* o = origins.data() + 3 * i;
                const Vec3 origin = scene.to_render(Vec3d(o[0], o[1], o[2]));
                for (int c = 0; c < 3; ++c) {
                    rays[8 * i + c] = origin[c];
                    rays[8 * i + 4 + c] = directions.data()[3 * i + c];
                }
                rays[8 * i + 7] = tfar;
            }
            GpuSceneData baked = bake_gpu_scene(scene, "pt", false, INFINITY, "");
            std::vector<float> out;
            {
                ReleasedGil release;
                VulkanCompute vk;
                out = gpu_trace_rays(vk, baked, rays.data(), n);
            }
            return to_array(out, {py::ssize_t(n), 4});
        },
        py::arg("scene"), py::arg("origins"), py::arg("directions"), py::arg("tfar"));
#else
    for (const char* name :
         {"bake_gpu_scene", "gpu_sample_steps", "gpu_sample_cut_steps", "gpu_trace_rays"})
        m.def(name, [](py::args, py::kwargs) { no_vulkan(); });
#endif
}

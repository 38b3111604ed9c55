// sssphere._image: image files through OpenImageIO, a module of its own so that
// `import sssphere` does not load OpenImageIO (and the ~200 libraries Debian's build of
// it links) until an image is read or written. Errors raise sssphere.SceneError, as in
// _core.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <vector>

#include "core/check.h"
#include "io/image_io.h"

namespace py = pybind11;

PYBIND11_MODULE(_image, m) {
    m.doc() =
        "Image files (OpenImageIO); use sssphere.read_image / sssphere.write_image.";
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const sss::Error& e) {
            py::object error = py::module_::import("sssphere._core").attr("SceneError");
            PyErr_SetString(error.ptr(), e.what());
        }
    });

    m.def(
        "write_image",
        [](const std::string& path,
           py::array_t<float, py::array::c_style | py::array::forcecast> img) {
            if (img.ndim() != 3 || (img.shape(2) != 3 && img.shape(2) != 1))
                sss::fail(
                    path,
                    ": image must have shape (height, width, 3) or (height, width, 1)");
            std::vector<float> px(img.data(), img.data() + img.size());
            py::gil_scoped_release release;
            sss::write_image(path, px, int(img.shape(1)), int(img.shape(0)),
                             int(img.shape(2)));
        },
        py::arg("path"), py::arg("image"));

    m.def(
        "read_image",
        [](const std::string& path) {
            int w, h, c;
            std::vector<float> px;
            {
                py::gil_scoped_release release;
                px = sss::read_image(path, &w, &h, &c);
            }
            py::array_t<float> a({py::ssize_t(h), py::ssize_t(w), py::ssize_t(c)});
            std::copy(px.begin(), px.end(), a.mutable_data());
            return a;
        },
        py::arg("path"));
}

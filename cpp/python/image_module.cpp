// sssphere._image: image files through OpenImageIO, a module of its own so that
// `import sssphere` does not load OpenImageIO (and the ~200 libraries Debian's build of
// it links) until an image is read or written. Errors raise sssphere.SceneError, as in
// _core.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <tuple>
#include <vector>

#include "core/check.h"
#include "io/image_io.h"
#include "python/released_gil.h"
#include "python/scene_error.h"

namespace py = pybind11;

PYBIND11_MODULE(_image, m) {
    m.doc() =
        "Image files (OpenImageIO); use sssphere.read_image / sssphere.write_image.";
    sss::init_released_gil(false);
    py::register_exception_translator(sss::translate_scene_errors);

    m.def(
        "write_image",
        [](const std::string& path,
           py::array_t<float, py::array::c_style | py::array::forcecast> img) {
            if (img.ndim() != 3 || (img.shape(2) != 3 && img.shape(2) != 1)) {
                std::string shape;
                for (py::ssize_t k = 0; k < img.ndim(); ++k)
                    shape += (k ? ", " : "") + std::to_string(img.shape(k));
                sss::fail(
                    path,
                    ": image must have shape (height, width, 3) or (height, width, 1), "
                    "got (",
                    shape, img.ndim() == 1 ? ",)" : ")");
            }
            std::vector<float> px(img.data(), img.data() + img.size());
            sss::ReleasedGil release;
            sss::write_image(path, px, int(img.shape(1)), int(img.shape(0)),
                             int(img.shape(2)));
        },
        py::arg("path"), py::arg("image"));

    m.def("check_output_image", &sss::check_output_image, py::arg("path"));
    m.def("check_output_is_not_an_input", &sss::check_output_is_not_an_input,
          py::arg("path"), py::arg("inputs"));

    m.def(
        "read_image",
        [](const std::string& path) {
            int w, h, c;
            std::vector<float> px;
            {
                sss::ReleasedGil release;
                px = sss::read_image(path, &w, &h, &c);
            }
            py::array_t<float> a({py::ssize_t(h), py::ssize_t(w), py::ssize_t(c)});
            std::copy(px.begin(), px.end(), a.mutable_data());
            return a;
        },
        py::arg("path"));

    m.def(
        "write_exr_layers",
        [](const std::string& path, const py::list& layers) {
            std::vector<sss::ImageLayer> out;
            int width = -1, height = -1;
            for (const py::handle& item : layers) {
                auto [name, channels, data] = item.cast<std::tuple<
                    std::string, std::vector<std::string>,
                    py::array_t<float, py::array::c_style | py::array::forcecast>>>();
                const size_t k = channels.size();
                if (data.ndim() != 3 || size_t(data.shape(2)) != k)
                    sss::fail(path, ": layer '", name,
                              "' must have shape (height, width, ", k, ")");
                if (width < 0) {
                    width = int(data.shape(1));
                    height = int(data.shape(0));
                } else if (data.shape(1) != width || data.shape(0) != height) {
                    sss::fail(path, ": layer '", name, "' is ", data.shape(1), " x ",
                              data.shape(0), ", the first one ", width, " x ", height);
                }
                out.push_back(
                    {name, channels,
                     std::vector<float>(data.data(), data.data() + data.size())});
            }
            if (out.empty()) sss::fail(path, ": no layers to write");
            sss::ReleasedGil release;
            sss::write_exr_layers(path, width, height, out);
        },
        py::arg("path"), py::arg("layers"));

    m.def(
        "read_exr_layers",
        [](const std::string& path) {
            int w, h;
            std::vector<std::string> names;
            std::vector<float> px;
            {
                sss::ReleasedGil release;
                px = sss::read_exr_layers(path, &w, &h, &names);
            }
            const size_t n = names.size();
            py::array_t<float> a({py::ssize_t(h), py::ssize_t(w), py::ssize_t(n)});
            std::copy(px.begin(), px.end(), a.mutable_data());
            return py::make_tuple(names, a);
        },
        py::arg("path"));
}

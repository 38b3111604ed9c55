// sssphere._core: the private binding. The Python package (python/sssphere) is the API;
// this module is a thin layer of numpy in / numpy out over the C++ facade.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <functional>
#include <optional>
#include <sstream>

#include "core/check.h"
#include "geometry/distance_grid.h"
#include "io/image_input.h"
#include "python/released_gil.h"
#include "python/render_progress.h"
#include "python/scene_error.h"
#include "render/medium_presets.h"
#include "render/renderer.h"
#include "render/scene.h"

namespace py = pybind11;
using namespace sss;

void bind_media(py::module_& m);   // bind_media.cpp
void bind_nn(py::module_& m);      // bind_nn.cpp
void bind_gpu(py::module_& m);     // bind_gpu.cpp
void bind_render(py::module_& m);  // bind_render.cpp

namespace {

// Points given in the scene file's coordinates, moved into the scene's render frame
// (SceneDesc::origin).
std::vector<Vec3> points_from(
    const Scene& scene,
    const py::array_t<double, py::array::c_style | py::array::forcecast>& p) {
    if (p.ndim() != 2 || p.shape(1) != 3)
        fail("points must have shape (n, 3), got ndim ", p.ndim());
    std::vector<Vec3> pts(p.shape(0));
    for (py::ssize_t i = 0; i < p.shape(0); ++i) {
        pts[i] = scene.to_render(Vec3d(p.at(i, 0), p.at(i, 1), p.at(i, 2)));
        if (!is_finite(pts[i]))  // CGAL's exact predicates trap on NaN (SIGFPE)
            fail("points[", i, "] = [", p.at(i, 0), ", ", p.at(i, 1), ", ", p.at(i, 2),
                 "] is not finite in single precision (relative to the shapes' centre)");
    }
    return pts;
}

const Shape& shape_at(const Scene& s, int i) {
    if (i < 0 || i >= s.num_shapes())
        fail("shape index ", i, " out of range [0, ", s.num_shapes(), ")");
    return s.desc().shapes[i];
}

}  // namespace

PYBIND11_MODULE(_core, m) {
    m.doc() = "sssphere native core (private; use the sssphere package)";
    init_released_gil(true);  // renders in daemon threads end before Python's exit
    py::register_exception<Error>(m, "SceneError", PyExc_ValueError).attr("__doc__") =
        "Bad input, in one line naming the file, the field, the value and what is "
        "allowed: "
        "a scene (file or dict), a mesh, a model file, a render option. A ValueError.";
    py::register_exception_translator(translate_scene_errors);  // tried before the above
    // Environment maps are read by sssphere._image (OpenImageIO, which _core does not
    // link), imported when a scene first needs one. Scenes are parsed holding the GIL.
    image_reader() = [](const std::string& path) {
        py::gil_scoped_acquire gil;
        py::array_t<float, py::array::c_style | py::array::forcecast> a;
        try {
            a = py::module_::import("sssphere._image").attr("read_image")(path);
        } catch (py::error_already_set& e) {
            fail(py::str(e.value()).cast<std::string>());  // the message, not its type
        }
        ImageData img;
        img.height = int(a.shape(0));
        img.width = int(a.shape(1));
        img.channels = int(a.shape(2));
        img.pixels.assign(a.data(), a.data() + a.size());
        return img;
    };
    bind_media(m);
    bind_nn(m);
    bind_gpu(m);
    bind_render(m);

    py::class_<MeshCache, std::shared_ptr<MeshCache>>(
        m, "MeshCache",
        "Meshes read from files, kept for parsing an edited scene again "
        "(render/scene.h).")
        .def(py::init<>());

    py::class_<Scene, std::shared_ptr<Scene>>(m, "Scene")
        .def(py::init([](const std::string& text, const std::string& base_dir,
                         const std::string& source, int threads,
                         std::shared_ptr<MeshCache> meshes) {
                 SceneDesc desc = parse_scene(text, base_dir, source, meshes.get());
                 SignalStop ctrl_c;  // a long grid build stops on Ctrl-C
                 try {
                     ReleasedGil release;
                     return std::make_shared<Scene>(std::move(desc), threads,
                                                    ctrl_c.stop());
                 } catch (const Cancelled&) {
                     ctrl_c.rethrow();
                 }
             }),
             py::arg("json_text"), py::arg("base_dir"), py::arg("source"),
             py::arg("threads") = 0, py::arg("meshes") = nullptr)
        .def(
            "_rebuild",
            [](Scene& s, const std::string& text, const std::string& base_dir,
               const std::string& source, int threads,
               std::shared_ptr<MeshCache> meshes) {
                SceneDesc desc = parse_scene(text, base_dir, source, meshes.get());
                std::optional<Scene> next;
                SignalStop ctrl_c;
                try {
                    ReleasedGil release;
                    next.emplace(std::move(desc), threads, s, ctrl_c.stop());
                } catch (const Cancelled&) {
                    ctrl_c.rethrow();  // the scene is unchanged
                }
                // Replaced with the GIL held: Python never reads half of it (renders,
                // which release the GIL, are kept apart by Scene._rendered in scene.py).
                s = std::move(*next);
            },
            py::arg("json_text"), py::arg("base_dir"), py::arg("source"),
            py::arg("threads") = 0, py::arg("meshes") = nullptr,
            "Replaces this scene by the one `json_text` describes, keeping the BVH and "
            "distance grids it can (Scene's reusing constructor, render/scene.h); on an "
            "error the scene is unchanged.")
        .def_property_readonly("rebuilt", &Scene::rebuilt,
                               "What the last build made anew (render/scene.h).")
        .def_property_readonly(
            "grid_resolutions", &Scene::grid_resolutions,
            "Distance grid cells along each shape's largest side (0: a "
            "surface).")
        .def_property_readonly(
            "width", [](const Scene& s) { return s.desc().camera.width; },
            "The image's width in pixels (camera.width).")
        .def_property_readonly(
            "height", [](const Scene& s) { return s.desc().camera.height; },
            "The image's height in pixels (camera.height).")
        .def_property_readonly(
            "source", [](const Scene& s) { return s.desc().source; },
            "Where the scene came from, as messages name it (its file, or '<dict>').")
        .def_property_readonly(
            "inputs", [](const Scene& s) { return s.desc().inputs; },
            "The files the scene reads, as paths: its meshes and environment maps (the "
            "scene file itself is source). A render's output may not be one of them.")
        .def_property_readonly(
            "base_dir", [](const Scene& s) { return s.desc().base_dir; },
            "The directory the scene's relative paths are read from.")
        .def_property_readonly(
            "warnings", [](const Scene& s) { return s.desc().warnings; },
            "Where the scene goes past the limits of docs/robustness.md (it renders, but "
            "maybe not within 1 %), one message each; loading raised SceneWarning for "
            "them.")
        .def_property_readonly(
            "integrator", [](const Scene& s) { return s.desc().render.integrator; },
            "render.integrator: 'pt' or 'st' (what a render uses unless told otherwise).")
        .def_property_readonly(
            "spp",
            [](const Scene& s) { return s.desc().render.spp.value_or(kDefaultSpp); },
            "render.spp, else the default samples per pixel.")
        .def_property_readonly(
            "seed", [](const Scene& s) { return s.desc().render.seed; },
            "render.seed (default 0).")
        .def_property_readonly(
            "max_bounces", [](const Scene& s) { return s.desc().render.max_bounces; },
            "render.max_bounces (-1: no limit).")
        .def_property_readonly(
            "sphere_threshold",
            [](const Scene& s) { return s.desc().render.sphere_threshold; },
            "render.sphere_threshold: st takes a sphere step where sigma_t * r >= it.")
        .def_property_readonly(
            "models",
            [](const Scene& s) -> std::optional<std::string> {
                if (s.desc().render.models.empty()) return std::nullopt;
                return s.desc().render.models;
            },
            "render.models: the model directory st uses (None: not set, "
            "the shipped models).")
        .def_property_readonly("num_shapes", &Scene::num_shapes,
                               "The number of shapes (media and surfaces).")
        .def(
            "shape_name", [](const Scene& s, int i) { return shape_at(s, i).name; },
            "The name of shape i: its 'name' field, else its place in the file "
            "('shapes[2]').")
        .def(
            "shape_mesh",
            [](const Scene& s, int i) {
                const TriangleMesh& mesh = shape_at(s, i).mesh;
                py::array_t<float> v(
                    {py::ssize_t(mesh.positions.size()), py::ssize_t(3)});
                py::array_t<uint32_t> f(
                    {py::ssize_t(mesh.triangles.size()), py::ssize_t(3)});
                auto out = v.mutable_unchecked<2>();
                for (size_t k = 0; k < mesh.positions.size(); ++k) {
                    const Vec3d p = s.to_scene(mesh.positions[k]);
                    for (int c = 0; c < 3; ++c) out(py::ssize_t(k), c) = float(p[c]);
                }
                std::memcpy(f.mutable_data(), mesh.triangles.data(),
                            mesh.triangles.size() * 3 * sizeof(uint32_t));
                return py::make_tuple(v, f);
            },
            "(vertices (n, 3) float32 in the scene file's coordinates, triangles (m, 3) "
            "uint32) of shape i.")
        .def(
            "shape_info",
            [](const Scene& s, int i) {
                const Shape& shape = shape_at(s, i);
                py::dict d;
                d["name"] = shape.name;
                d["triangles"] = shape.mesh.triangles.size();
                d["vertices"] = shape.mesh.positions.size();
                d["area"] = shape.mesh.area();
                d["volume"] = shape.is_surface() ? 0.0 : shape.mesh.volume();
                if (shape.is_surface()) {
                    d["kind"] = "surface";
                    d["surface"] = shape.surface.kind().name;
                    d["color"] =
                        std::vector<float>{shape.surface.color.x, shape.surface.color.y,
                                           shape.surface.color.z};
                    return d;
                }
                const Medium& m = shape.medium;
                d["kind"] = "medium";
                d["sigma_t"] = std::vector<float>{m.sigma_t.x, m.sigma_t.y, m.sigma_t.z};
                d["albedo"] = std::vector<float>{m.albedo.x, m.albedo.y, m.albedo.z};
                d["phase"] = m.phase.kind().name;
                d["g"] = m.phase.kind().mean_cosine(m.phase);
                d["boundary"] = shape.boundary.kind().name;
                // The relative index of refraction (a dielectric keeps it in x).
                d["ior"] = std::string(shape.boundary.kind().name) == "dielectric"
                               ? shape.boundary.x
                               : 1.f;
                d["grid_resolution"] = s.grid_resolutions()[i];
                d["surfaces_meeting"] = s.surfaces_meeting(i);
                return d;
            },
            "Shape i in brief: name, kind ('medium' or 'surface'), triangles, vertices, "
            "area and volume (render units = scene units); a medium's sigma_t, albedo, "
            "phase, g (mean cosine), boundary, ior and grid_resolution; a surface's type "
            "and color.")
        .def(
            "distance_lower_bound",
            [](const Scene& s, int i,
               py::array_t<double, py::array::c_style | py::array::forcecast> p) {
                shape_at(s, i);
                std::vector<Vec3> pts = points_from(s, p);
                std::vector<float> r(pts.size());
                for (size_t k = 0; k < pts.size(); ++k) r[k] = s.grid(i).query(pts[k]);
                return to_array(r, {py::ssize_t(r.size())});
            },
            "For each point (an (n, 3) array, scene coordinates), shape i's distance "
            "grid's conservative lower bound on its distance to the surface: what a "
            "sphere step's radius comes from (0 outside the grid).")
        .def(
            "grid_inside",
            [](const Scene& s, int i,
               py::array_t<double, py::array::c_style | py::array::forcecast> p) {
                shape_at(s, i);
                std::vector<Vec3> pts = points_from(s, p);
                py::array_t<bool> out(py::ssize_t(pts.size()));
                auto o = out.mutable_unchecked<1>();
                for (size_t k = 0; k < pts.size(); ++k)
                    o(py::ssize_t(k)) = s.grid(i).inside(pts[k]);
                return out;
            },
            "Whether each point (scene coordinates) is inside shape i's medium, by its "
            "distance grid's sign at the nearest node: a guess within a cell of the "
            "surface (for statistics over a volume).")
        .def(
            "exact_distance",
            [](const Scene& s, int i,
               py::array_t<double, py::array::c_style | py::array::forcecast> p) {
                std::vector<double> d =
                    exact_distances(shape_at(s, i).mesh, points_from(s, p));
                return to_array(d, {py::ssize_t(d.size())});
            },
            "For each point (an (n, 3) array, scene coordinates), its exact distance to "
            "shape i's mesh (CGAL's AABB tree; a test oracle for distance_lower_bound).")
        .def("__repr__", [](const Scene& s) {
            std::ostringstream os;
            os << "<sssphere.Scene '" << s.desc().source << "': " << s.desc().camera.width
               << "x" << s.desc().camera.height << ", " << s.num_shapes() << " shape(s), "
               << s.desc().lights.size() << " light(s), integrator '"
               << s.desc().render.integrator << "', "
               << s.desc().render.spp.value_or(kDefaultSpp) << " spp>";
            return os.str();
        });

    m.def(
        "load_mesh",
        [](const std::string& path) {
            TriangleMesh mesh = load_mesh(path);
            py::array_t<float> v({py::ssize_t(mesh.positions.size()), py::ssize_t(3)});
            py::array_t<uint32_t> f({py::ssize_t(mesh.triangles.size()), py::ssize_t(3)});
            auto out = v.mutable_unchecked<2>();
            for (size_t k = 0; k < mesh.positions.size(); ++k) {
                const Vec3d p = mesh.origin + Vec3d(mesh.positions[k]);
                for (int c = 0; c < 3; ++c) out(py::ssize_t(k), c) = float(p[c]);
            }
            std::memcpy(f.mutable_data(), mesh.triangles.data(),
                        mesh.triangles.size() * 3 * sizeof(uint32_t));
            return py::make_tuple(v, f);
        },
        py::arg("path"),
        "Loads, checks and orients a closed mesh: (vertices, triangles).");

    m.def(
        "light_to_mitsuba",
        [](const std::string& light_json) {
            // Checked as in a scene file first, so that the translation sees valid input.
            const Light l = parse_light(light_json, "<light>");
            return l.kind().mitsuba(nlohmann::json::parse(light_json)).dump();
        },
        py::arg("light_json"),
        "A scene file's light (JSON text) as a Mitsuba 3 load_dict entry (JSON text; "
        "colours {\"$rgb\": [r, g, b]}, transforms {\"$matrix\": rows}).");

    m.def(
        "boundary_to_mitsuba",
        [](const std::string& boundary_json) {
            const Boundary b = parse_boundary(boundary_json, "<boundary>");
            return b.kind().mitsuba(nlohmann::json::parse(boundary_json)).dump();
        },
        py::arg("boundary_json"),
        "A scene file's boundary (JSON text) as the BSDF of a Mitsuba 3 shape (JSON "
        "text).");

    m.def(
        "surface_to_mitsuba",
        [](const std::string& surface_json) {
            const Surface sf = parse_surface(surface_json, "<surface>");
            return sf.kind().mitsuba(nlohmann::json::parse(surface_json)).dump();
        },
        py::arg("surface_json"),
        "A scene file's opaque surface (JSON text) as the BSDF of a Mitsuba 3 shape "
        "(JSON "
        "text).");

    m.def(
        "edit_scene_json", &edit_scene_json, py::arg("json_text"), py::arg("source"),
        py::arg("assignments"), py::arg("width") = 0, py::arg("height") = 0,
        "A scene's JSON text with the command lines' --set PATH=VALUE changes and image "
        "size (render/scene.h).");

    m.def(
        "medium_coefficients",
        [](const std::string& medium_json) {
            const Medium med = parse_medium(medium_json, "<medium>");
            auto rgb = [](Vec3 v) { return std::vector<float>{v.x, v.y, v.z}; };
            py::dict d;
            d["sigma_t"] = rgb(med.sigma_t);
            d["albedo"] = rgb(med.albedo);
            return d;
        },
        py::arg("medium_json"),
        "A scene file's medium (JSON text, stated any way the format allows) as sigma_t "
        "(per scene unit) and albedo, RGB.");

    m.def(
        "medium_presets",
        [] {
            auto rgb = [](Vec3 v) { return std::vector<float>{v.x, v.y, v.z}; };
            py::list out;
            for (const MediumPreset& p : medium_presets()) {
                py::dict d;
                d["name"] = p.name;
                d["sigma_s_prime"] = rgb(p.sigma_s_prime);
                d["sigma_a"] = rgb(p.sigma_a);
                d["ior"] = p.ior > 0.f ? py::object(py::float_(p.ior)) : py::none();
                d["source"] = p.source;
                out.append(d);
            }
            return out;
        },
        "The measured media a scene's \"preset\" names (render/medium_presets.h): "
        "reduced scattering and absorption in mm^-1, RGB, the index of refraction where "
        "the source gives one, and the source.");

    m.def(
        "phase_to_mitsuba",
        [](const std::string& medium_json) {
            const Phase p = parse_phase(medium_json, "<medium>");
            const nlohmann::json j = nlohmann::json::parse(medium_json);
            return p.kind().mitsuba(j.contains("phase") ? j["phase"] : j).dump();
        },
        py::arg("medium_json"),
        "A scene file's medium (JSON text) to the phase entry of its Mitsuba 3 medium "
        "(JSON text).");
}

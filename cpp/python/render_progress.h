// What the render bindings share: numpy arrays from vectors, a render's result as a
// dict, and the progress callback a render calls without the GIL
// (Python's progress function, Ctrl-C, and the exception a callback raised, kept to be
// rethrown once the render returned).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <vector>

#include "python/released_gil.h"
#include "render/film.h"

namespace sss {

template <typename T>
pybind11::array_t<T> to_array(const std::vector<T>& v,
                              std::vector<pybind11::ssize_t> shape) {
    pybind11::array_t<T> a(shape);
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
}

// Hidden like pybind11's own types, which it holds.
// A RenderResult (render/film.h), CPU or GPU, as the dict
// python/sssphere/rendering.py reads: images (H, W, ...), per-path counts with
// record_paths (spp, H, W), time, totals.
inline pybind11::dict film_dict(const RenderResult& r, int spp, bool record_paths,
                                bool interrupted) {
    const pybind11::ssize_t H = r.height, W = r.width;
    pybind11::dict d;
    d["image"] = to_array(r.image, {H, W, 3});
    d["variance"] = to_array(r.variance, {H, W, 3});
    d["events"] = to_array(r.events, {H, W});
    d["sphere_steps"] = to_array(r.sphere_steps, {H, W});
    d["samples"] = to_array(r.samples, {H, W});
    if (record_paths) {
        d["path_events"] = to_array(r.path_events, {pybind11::ssize_t(spp), H, W});
        d["path_steps"] = to_array(r.path_steps, {pybind11::ssize_t(spp), H, W});
    }
    d["seconds"] = r.seconds;
    d["cancelled"] = r.cancelled;
    d["time_limit_reached"] = r.time_limit_reached;
    d["spp"] = r.spp;
    d["interrupted"] = interrupted;
    d["total_events"] = r.total_events;
    d["total_sphere_steps"] = r.total_sphere_steps;
    d["total_paths"] = r.total_paths;
    d["warnings"] = r.warnings;
    return d;
}

// Python's bool or NumPy's (numpy.bool_, named "bool" since NumPy 2).
inline bool is_bool(const pybind11::handle& v) {
    if (PyBool_Check(v.ptr())) return true;
    const pybind11::handle type = pybind11::type::of(v);
    const std::string name = pybind11::str(type.attr("__name__"));
    return (name == "bool_" || name == "bool") &&
           std::string(pybind11::str(type.attr("__module__"))) == "numpy";
}

struct __attribute__((visibility("hidden"))) RenderProgress {
    explicit RenderProgress(pybind11::object callback) : progress(std::move(callback)) {}

    pybind11::object progress;  // None or progress(fraction) -> bool or None
    bool interrupted = false;   // Ctrl-C (or KeyboardInterrupt from the callback)
    std::optional<pybind11::error_already_set> error;  // another exception it raised

    // Called by the renderer (GIL released): false stops the render.
    bool operator()(double fraction) {
        if (gil_would_end_this_thread())
            return false;  // the GIL would end this thread (released_gil.h)
        pybind11::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
            PyErr_Clear();  // a pending KeyboardInterrupt: stop and report it
            interrupted = true;
            return false;
        }
        if (progress.is_none()) return true;
        try {
            pybind11::object r = progress(fraction);
            if (r.is_none()) return true;
            if (is_bool(r)) return r.cast<bool>();
            // not a truth value but a mistake ("no", 0)
            PyErr_SetString(
                PyExc_TypeError,
                ("the progress callback must return True, False or None (False "
                 "stops the render), got " +
                 std::string(pybind11::repr(r)))
                    .c_str());
            throw pybind11::error_already_set();
        } catch (pybind11::error_already_set& e) {
            if (e.matches(PyExc_KeyboardInterrupt))
                interrupted = true;
            else
                error = std::move(e);
            return false;
        }
    }
    // After the render, with the GIL held: rethrows the callback's exception.
    void rethrow() {
        if (error) throw *error;
    }
};

}  // namespace sss

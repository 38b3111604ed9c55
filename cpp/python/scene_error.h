// sss::Error as Python's sssphere.SceneError, for both extension modules (_core, _image).
#pragma once

#include <pybind11/pybind11.h>

#include <cstring>
#include <exception>

#include "core/check.h"

namespace sss {

// Registered after _core creates SceneError. Bytes of the message that are not UTF-8 (a
// malformed file's text, quoted in a parse error, can end inside a character) are shown
// as \xNN: left to pybind11 they would turn the error into a UnicodeDecodeError.
inline void translate_scene_errors(std::exception_ptr p) {
    namespace py = pybind11;
    try {
        if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
        py::object type = py::module_::import("sssphere._core").attr("SceneError");
        py::object message = py::reinterpret_steal<py::object>(PyUnicode_DecodeUTF8(
            e.what(), Py_ssize_t(std::strlen(e.what())), "backslashreplace"));
        PyErr_SetObject(type.ptr(), message.ptr());
    }
}

}  // namespace sss

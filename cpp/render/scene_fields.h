// The scene file's value types (numbers in a range, vectors, positions, RGB, strings from
// a list) read with errors that name the file, the field and what is allowed: used by the
// scene parser (render/scene.cpp) and the light types (render/lights/).
#pragma once

#include <initializer_list>
#include <string>

#include "core/vec.h"
#include "io/json_fields.h"

namespace sss::json_fields {

inline double number_in(const json& j, const Field& f, double lo, double hi,
                        const char* allowed) {
    double v = number(j, f);
    if (!(v >= lo && v <= hi))
        f.error("value ", show(j), " is not allowed (allowed: ", allowed, ")");
    return v;
}

inline Vec3 vec3(const json& j, const Field& f) {
    if (!j.is_array() || j.size() != 3)
        f.error("expected an array of 3 numbers, got ", show(j));
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = float(number(j[i], f.at(size_t(i))));
    if (!is_finite(v)) f.error("value ", show(j), " does not fit in single precision");
    return v;
}

// A position, kept in double until the scene is moved into its render frame.
inline Vec3d point3(const json& j, const Field& f) {
    if (!j.is_array() || j.size() != 3)
        f.error("expected an array of 3 numbers, got ", show(j));
    Vec3d v;
    for (int i = 0; i < 3; ++i) v[i] = number(j[i], f.at(size_t(i)));
    if (!is_finite(v.to_float()))
        f.error("value ", show(j), " does not fit in single precision");
    return v;
}

// RGB with each component in [lo, hi]; a single number means grey.
// The range is checked on the file's numbers, before rounding to float (which takes
// 1e30 past 1e30).
inline Vec3 rgb_in(const json& j, const Field& f, double lo, double hi,
                   const char* allowed) {
    if (!j.is_number() && (!j.is_array() || j.size() != 3))
        f.error("expected a number or an array of 3 numbers, got ", show(j));
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
        const bool grey = j.is_number();
        double c = number(grey ? j : j[i], grey ? f : f.at(size_t(i)));
        if (!(c >= lo && c <= hi))
            f.error("value ", show(j), " is not allowed (allowed: ", allowed, ")");
        v[i] = float(c);
    }
    return v;
}

// A direction (its length does not matter). One too short for float's length (|v|^2
// underflows: [1e-30, 0, 0]) is scaled to a largest component of 1 in double: it was
// refused as "not a non-zero vector".
inline Vec3 nonzero_vec3(const json& j, const Field& f) {
    const Vec3 v = vec3(j, f);
    if (length(v) > 0.f) return v;
    double c[3], largest = 0.0;
    for (int i = 0; i < 3; ++i) {
        c[i] = j[i].get<double>();
        largest = std::max(largest, std::abs(c[i]));
    }
    if (!(largest > 0.0))
        f.error("value ", show(j), " is not allowed (allowed: a non-zero vector)");
    return Vec3(float(c[0] / largest), float(c[1] / largest), float(c[2] / largest));
}

inline std::string string_in(const json& j, const Field& f,
                             std::initializer_list<const char*> allowed) {
    if (!j.is_string()) f.error("expected a string, got ", type_name(j), " ", show(j));
    std::string s = j.get<std::string>();
    std::string list;
    for (const char* a : allowed) {
        if (s == a) return s;
        list += std::string(list.empty() ? "" : ", ") + "\"" + a + "\"";
    }
    f.error("value ", show(j), " is not allowed (allowed: ", list, ")");
}

}  // namespace sss::json_fields

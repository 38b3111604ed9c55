// Reading JSON files (scenes, model files) with errors that name the file, the field, the
// value and what is allowed: "<source>: shapes[0].medium.g: value 1.2 is not allowed
// (...)". Shared by render/scene.cpp and nn/decoder.cpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "core/check.h"

namespace sss::json_fields {

using json = nlohmann::json;

// Where we are in the file, for messages.
struct Field {
    const std::string& source;
    std::string path;

    Field at(const std::string& key) const {
        return {source, path.empty() ? key : path + "." + key};
    }
    Field at(size_t i) const { return {source, path + "[" + std::to_string(i) + "]"}; }

    template <typename... Args>
    [[noreturn]] void error(const Args&... args) const {
        if (path.empty()) fail(source, ": ", args...);
        fail(source, ": ", path, ": ", args...);
    }
};

// A value for a message, shortened.
inline std::string show(const json& j) {
    std::string s = j.dump();
    return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

inline const char* type_name(const json& j) {
    switch (j.type()) {
        case json::value_t::null:
            return "null";
        case json::value_t::boolean:
            return "a boolean";
        case json::value_t::string:
            return "a string";
        case json::value_t::array:
            return "an array";
        case json::value_t::object:
            return "an object";
        default:
            return "a number";
    }
}

// Unknown keys are errors (parameter names are a contract: docs/architecture.md).
inline void check_keys(const json& obj, const Field& f,
                       std::initializer_list<const char*> allowed) {
    if (!obj.is_object())
        f.error("expected an object, got ", type_name(obj), " ", show(obj));
    std::set<std::string> ok(allowed.begin(), allowed.end());
    for (auto it = obj.begin(); it != obj.end(); ++it) {
        if (!ok.count(it.key())) {
            std::string list;
            for (const char* a : allowed)
                list += std::string(list.empty() ? "" : ", ") + a;
            f.at(it.key()).error("unknown key '", it.key(), "' (allowed here: ", list,
                                 ")");
        }
    }
}

inline const json& require(const json& obj, const char* key, const Field& f) {
    auto it = obj.find(key);
    if (it == obj.end()) f.error("missing required key '", key, "'");
    return *it;
}

// A finite number.
inline double number(const json& j, const Field& f) {
    if (!j.is_number()) f.error("expected a number, got ", type_name(j), " ", show(j));
    double v = j.get<double>();
    if (!std::isfinite(v)) f.error("value ", show(j), " is not a finite number");
    return v;
}

// An integer in [lo, hi]; `allowed` describes the range for the message.
inline int64_t integer_in(const json& j, const Field& f, int64_t lo, int64_t hi,
                          const char* allowed) {
    if (!j.is_number_integer())
        f.error("expected an integer, got ", type_name(j), " ", show(j));
    if (j.is_number_unsigned() && j.get<uint64_t>() > uint64_t(INT64_MAX))
        f.error("value ", show(j), " is not allowed (allowed: ", allowed, ")");
    int64_t v = j.get<int64_t>();
    if (v < lo || v > hi)
        f.error("value ", show(j), " is not allowed (allowed: ", allowed, ")");
    return v;
}

}  // namespace sss::json_fields

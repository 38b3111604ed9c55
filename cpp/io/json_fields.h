// Reading JSON files (scenes, model files) with errors that name the file, the field, the
// value and what is allowed: "<source>: shapes[0].medium.g: value 1.2 is not allowed
// (...)". Shared by render/scene.cpp and nn/decoder.cpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

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

// A value as messages show it: its type and text ("a string \"x\"", "an array [1,2]";
// null is "null" alone).
inline std::string described(const json& j) {
    return j.is_null() ? std::string("null") : std::string(type_name(j)) + " " + show(j);
}

// Parsed files nest at most this deep (scenes need 4 levels, model files 5); deeper input
// is refused while it is parsed, before it can exhaust the stack of a recursive consumer.
constexpr int kMaxJsonDepth = 64;

// `s` with each byte that is not part of well-formed UTF-8 written as \xNN, as Python's
// "backslashreplace" writes it: a parser's message quotes the bytes it stopped at, and a
// stray byte (a file that starts with two byte-order marks) made stderr invalid UTF-8.
inline std::string utf8_or_escaped(const std::string& s) {
    std::string out;
    for (size_t i = 0; i < s.size();) {
        const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[i + k]); };
        const unsigned char c = byte(0);
        const size_t n = c < 0x80   ? 1
                         : c < 0xC2 ? 0
                         : c < 0xE0 ? 2
                         : c < 0xF0 ? 3
                         : c < 0xF5 ? 4
                                    : 0;
        bool ok = n > 0 && i + n <= s.size();
        for (size_t k = 1; ok && k < n; ++k) ok = (byte(k) & 0xC0) == 0x80;
        // No overlong forms, surrogates or code points past U+10FFFF
        if (ok && n >= 3) {
            const unsigned char d = byte(1);
            ok = !(c == 0xE0 && d < 0xA0) && !(c == 0xED && d >= 0xA0) &&
                 !(c == 0xF0 && d < 0x90) && !(c == 0xF4 && d >= 0x90);
        }
        if (ok) {
            out.append(s, i, n);
            i += n;
            continue;
        }
        const char* hex = "0123456789abcdef";
        out += {'\\', 'x', hex[c >> 4], hex[c & 15]};
        ++i;
    }
    return out;
}

// Parses `text` (named `source` in messages): malformed JSON, nesting deeper than
// kMaxJsonDepth and an object with the same key twice (which JSON parsers otherwise
// resolve silently, the last one winning) are errors naming the place.
// `hint` (optional) adds a sentence to the message of malformed JSON.
inline json parse_json(const std::string& text, const std::string& source,
                       const std::function<std::string()>& hint = {}) {
    // The path to where the parser is, one entry per open object or array, for messages.
    struct Level {
        bool object;
        std::string name;            // how the parent names this level
        std::set<std::string> keys;  // objects: the keys seen so far
        std::string key;             // objects: the last key
        size_t index = 0;            // arrays: the next element's index
    };
    std::vector<Level> levels;
    auto where = [&]() {
        std::string path;
        for (size_t i = 1; i < levels.size(); ++i) path += levels[i].name;
        if (!levels.empty() && levels.back().object && !levels.back().key.empty())
            path += (path.empty() ? "" : ".") + levels.back().key;
        if (path.size() > 60) path = path.substr(0, 57) + "...";
        return path.empty() ? std::string("(top level)") : path;
    };
    auto child_name = [&]() -> std::string {
        if (levels.empty()) return "";
        Level& parent = levels.back();
        if (parent.object) return (levels.size() > 1 ? "." : "") + parent.key;
        return "[" + std::to_string(parent.index++) + "]";
    };
    json::parser_callback_t cb = [&](int depth, json::parse_event_t event, json& parsed) {
        using E = json::parse_event_t;
        if (depth > kMaxJsonDepth)
            fail(source, ": ", where(), ": JSON nested deeper than ", kMaxJsonDepth,
                 " levels (allowed: at most ", kMaxJsonDepth, ")");
        switch (event) {
            case E::object_start:
            case E::array_start: {
                std::string name = child_name();
                levels.push_back({event == E::object_start, name, {}, {}, 0});
                break;
            }
            case E::object_end:
            case E::array_end:
                if (!levels.empty()) levels.pop_back();
                break;
            case E::key: {
                Level& l = levels.back();
                const std::string key = parsed.get<std::string>();
                l.key = key;
                if (!l.keys.insert(key).second)
                    fail(source, ": ", where(), ": key '", key,
                         "' appears twice in one object (allowed: once)");
                break;
            }
            case E::value:
                if (!levels.empty() && !levels.back().object) ++levels.back().index;
                break;
        }
        return true;
    };
    try {
        return json::parse(text, cb);
    } catch (const json::exception& e) {
        // nlohmann's message, without the name of its exception class
        // ("[json.exception.parse_error.101] "), after the field it was reading (an
        // overflowing number has no line and column).
        std::string what = utf8_or_escaped(e.what());
        if (what.rfind("[json.exception.", 0) == 0 &&
            what.find("] ") != std::string::npos)
            what = what.substr(what.find("] ") + 2);
        const std::string at = levels.empty() ? std::string() : " at " + where();
        if (text.find("NaN") != std::string::npos ||
            text.find("Infinity") != std::string::npos)
            what +=
                " (NaN and Infinity are not JSON numbers: Python's json.dump writes "
                "them unless allow_nan=False)";
        fail(source, ": malformed JSON", at, ": ", what, hint ? hint() : std::string());
    }
}

// Unknown keys are errors (parameter names are a contract: docs/architecture.md).
inline void check_keys(const json& obj, const Field& f,
                       const std::vector<const char*>& allowed) {
    if (!obj.is_object()) f.error("expected an object, got ", described(obj));
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
inline void check_keys(const json& obj, const Field& f,
                       std::initializer_list<const char*> allowed) {
    check_keys(obj, f, std::vector<const char*>(allowed));
}

inline const json& require(const json& obj, const char* key, const Field& f) {
    auto it = obj.find(key);
    if (it == obj.end()) f.error("missing required key '", key, "'");
    return *it;
}

// A finite number. A negative zero reads as zero: it passes every `>= 0` check, yet its
// reciprocal is -inf (a "free flight" of -inf in a medium of sigma_t -0.0).
inline double number(const json& j, const Field& f) {
    if (!j.is_number()) f.error("expected a number, got ", described(j));
    double v = j.get<double>();
    if (!std::isfinite(v)) f.error("value ", show(j), " is not a finite number");
    return v + 0.0;
}

inline std::string string_of(const json& j, const Field& f) {
    if (!j.is_string()) f.error("expected a string, got ", type_name(j), " ", show(j));
    return j.get<std::string>();
}

// The "format" and "format_version" of a versioned file (a model file: nn/decoder.h,
// nn/step_tilt.h), checked before anything else, so that a file of another kind or
// version is reported as such rather than by its first unexpected key. `kind` names the
// files of this format in the message ("a decoder file").
inline void check_format(const json& obj, const Field& root, const char* format,
                         int version, const char* kind) {
    const std::string found = string_of(require(obj, "format", root), root.at("format"));
    if (found != format)
        fail(root.source, ": format \"", found, "\" is not ", kind,
             " (this build reads format \"", format, "\", format_version ", version, ")");
    const json& v = require(obj, "format_version", root);
    if (!v.is_number_integer() || v.get<int64_t>() != version)
        fail(root.source, ": format_version ", show(v),
             " is not supported (this build reads format_version ", version, ")");
}

// An integer in [lo, hi]; `allowed` describes the range for the message.
inline int64_t integer_in(const json& j, const Field& f, int64_t lo, int64_t hi,
                          const char* allowed) {
    // An integer past 2^64 - 1, or below -2^63, reaches us as a float (the JSON parser's
    // choice): it is out of range, not "not an integer".
    if (j.is_number_float() && std::isfinite(j.get<double>()) &&
        std::abs(j.get<double>()) >= 0x1p63 &&
        std::floor(j.get<double>()) == j.get<double>())
        f.error("value ", show(j), " is not allowed (allowed: ", allowed, ")");
    if (!j.is_number_integer()) f.error("expected an integer, got ", described(j));
    if (j.is_number_unsigned() && j.get<uint64_t>() > uint64_t(INT64_MAX))
        f.error("value ", show(j), " is not allowed (allowed: ", allowed, ")");
    int64_t v = j.get<int64_t>();
    if (v < lo || v > hi)
        f.error("value ", show(j), " is not allowed (allowed: ", allowed, ")");
    return v;
}

}  // namespace sss::json_fields

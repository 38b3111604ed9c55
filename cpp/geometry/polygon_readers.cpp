#include "geometry/polygon_readers.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/check.h"
#include "core/files.h"

namespace sss {

namespace {

// A face with more vertices than this is refused (a few bytes could otherwise ask for
// gigabytes).
constexpr uint64_t kMaxFaceVertices = uint64_t(1) << 16;

std::string read_all(const std::string& path) {
    return read_input_file(path, "mesh file");
}

// `data` without a UTF-8 byte order mark at its start (editors on Windows write one)
std::string without_bom(std::string data) {
    if (data.rfind("\xEF\xBB\xBF", 0) == 0) data.erase(0, 3);
    return data;
}

std::vector<std::string> words_of(const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> words;
    for (std::string w; in >> w;) words.push_back(w);
    return words;
}

// A word as an error message may quote it: at most 24 bytes, control bytes as '?'.
std::string quoted(const std::string& w) {
    std::string q = w.substr(0, 24);
    for (char& c : q)
        if (std::iscntrl(static_cast<unsigned char>(c))) c = '?';
    return q.size() < w.size() ? q + "..." : q;
}

bool parse_double(const std::string& s, double& v) {
    char* end = nullptr;
    errno = 0;
    v = std::strtod(s.c_str(), &end);
    return !s.empty() && *end == '\0';
}

bool parse_count(const std::string& s, uint64_t max, uint64_t& v) {
    char* end = nullptr;
    errno = 0;
    const long long n = std::strtoll(s.c_str(), &end, 10);
    if (s.empty() || *end != '\0' || errno == ERANGE || n < 0 || uint64_t(n) > max)
        return false;
    v = uint64_t(n);
    return true;
}

// A vertex index read as a number (PLY stores them in any numeric type).
std::size_t index_of(double v, const std::string& path, const char* where) {
    if (!(v >= 0.0 && v < 9007199254740992.0) || v != double(uint64_t(v)))
        fail(path, ": ", where, ": vertex index ", v,
             " is not allowed (allowed: integers >= 0)");
    return std::size_t(v);
}

// --- PLY ---------------------------------------------------------------------------

enum class Type { I8, U8, I16, U16, I32, U32, F32, F64 };

bool parse_type(const std::string& s, Type& t) {
    static const struct {
        const char* a;
        const char* b;
        Type t;
    } kTypes[] = {{"char", "int8", Type::I8},      {"uchar", "uint8", Type::U8},
                  {"short", "int16", Type::I16},   {"ushort", "uint16", Type::U16},
                  {"int", "int32", Type::I32},     {"uint", "uint32", Type::U32},
                  {"float", "float32", Type::F32}, {"double", "float64", Type::F64}};
    for (const auto& k : kTypes)
        if (s == k.a || s == k.b) {
            t = k.t;
            return true;
        }
    return false;
}

int size_of(Type t) {
    switch (t) {
        case Type::I8:
        case Type::U8:
            return 1;
        case Type::I16:
        case Type::U16:
            return 2;
        case Type::I32:
        case Type::U32:
        case Type::F32:
            return 4;
        case Type::F64:
            return 8;
    }
    return 1;
}

struct Property {
    std::string name;
    bool list = false;
    Type count_type = Type::U8, type = Type::F32;
};

struct Element {
    std::string name;
    uint64_t count = 0;
    std::vector<Property> properties;
};

// The values of a PLY body, one at a time, in its encoding. Running out is an error
// naming the element being read.
class PlyBody {
public:
    enum class Format { Ascii, Little, Big };
    PlyBody(const std::string& path, const std::string& data, size_t at, Format format)
        : path_(path), data_(data), at_(at), format_(format) {}

    double next(Type t, const std::string& where) {
        if (format_ == Format::Ascii) return next_word(t, where);
        const int n = size_of(t);
        if (at_ > data_.size() || data_.size() - at_ < size_t(n))
            fail(path_, ": the file ends in ", where);
        unsigned char b[8];
        std::memcpy(b, data_.data() + at_, size_t(n));
        at_ += size_t(n);
        const bool swap = (format_ == Format::Big) == little_endian_host();
        if (swap)
            for (int i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
        switch (t) {
            case Type::I8:
                return double(int8_t(b[0]));
            case Type::U8:
                return double(b[0]);
            case Type::I16:
                return double(load<int16_t>(b));
            case Type::U16:
                return double(load<uint16_t>(b));
            case Type::I32:
                return double(load<int32_t>(b));
            case Type::U32:
                return double(load<uint32_t>(b));
            case Type::F32:
                return double(load<float>(b));
            case Type::F64:
                return load<double>(b);
        }
        return 0.0;
    }

    // After an item: in ASCII the rest of its line must be blank (an item to a line, as
    // PLY writers write them). More values there mean a header whose counts or
    // properties do not match the body, which would read on as garbage.
    void end_item(const std::string& where) {
        if (format_ != Format::Ascii) return;
        while (at_ < data_.size() && data_[at_] != '\n' &&
               std::isspace((unsigned char)data_[at_]))
            ++at_;
        if (at_ < data_.size() && data_[at_] != '\n')
            fail(path_, ": line ", line(), ": ", where,
                 " ends before its line does: do the header's element counts and "
                 "properties match the body? (allowed: an item to a line)");
    }

    // After the last element: in ASCII nothing but blanks may follow.
    void end_body() {
        if (format_ != Format::Ascii) return;
        while (at_ < data_.size() && std::isspace((unsigned char)data_[at_])) ++at_;
        if (at_ < data_.size())
            fail(path_, ": line ", line(),
                 ": values after the last element: do the header's element counts match "
                 "the body?");
    }

private:
    // The line the body is at, counted from the file's first (for ASCII errors).
    int line() const {
        const size_t end = std::min(at_, data_.size());
        return 1 + int(std::count(data_.begin(), data_.begin() + long(end), '\n'));
    }
    static bool little_endian_host() {
        const uint16_t one = 1;
        unsigned char c;
        std::memcpy(&c, &one, 1);
        return c == 1;
    }
    template <typename T>
    static T load(const unsigned char* b) {
        T v;
        std::memcpy(&v, b, sizeof v);
        return v;
    }
    double next_word(Type t, const std::string& where) {
        while (at_ < data_.size() && std::isspace((unsigned char)data_[at_])) ++at_;
        const size_t start = at_;
        while (at_ < data_.size() && !std::isspace((unsigned char)data_[at_])) ++at_;
        if (start == at_) fail(path_, ": the file ends in ", where);
        const std::string word = data_.substr(start, at_ - start);
        double v = 0.0;
        const bool integer = t != Type::F32 && t != Type::F64;
        if (!parse_double(word, v) ||
            (integer && !(std::fabs(v) < 9.2e18 && v == std::trunc(v))))
            fail(path_, ": line ", line(), ": ", where, ": '", quoted(word), "' is not ",
                 integer ? "an integer" : "a number");
        return v;
    }

    const std::string& path_;
    const std::string& data_;
    size_t at_;
    Format format_;
};

}  // namespace

PolygonSoup read_ply(const std::string& path) {
    const std::string data = without_bom(read_all(path));
    // The header: "ply", a format line, then comment, obj_info, element and property
    // lines up to end_header.
    std::vector<Element> elements;
    PlyBody::Format format = PlyBody::Format::Ascii;
    bool have_format = false, ended = false;
    size_t at = 0;
    for (int n = 1; at < data.size() && !ended; ++n) {
        size_t eol = data.find('\n', at);
        if (eol == std::string::npos) eol = data.size();
        std::string line = data.substr(at, eol - at);
        at = std::min(eol + 1, data.size());  // a last line without '\n' ends the data
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::vector<std::string> w = words_of(line);
        auto bad = [&](const char* why) {
            fail(path, ": malformed PLY header, line ", n, ": ", why);
        };
        if (n == 1) {
            if (w.size() != 1 || w[0] != "ply") bad("the file must start with 'ply'");
        } else if (w.empty() || w[0] == "comment" || w[0] == "obj_info") {
            continue;
        } else if (w[0] == "format") {
            if (w.size() != 3 || w[2] != "1.0")
                bad("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
            if (w[1] == "ascii")
                format = PlyBody::Format::Ascii;
            else if (w[1] == "binary_little_endian")
                format = PlyBody::Format::Little;
            else if (w[1] == "binary_big_endian")
                format = PlyBody::Format::Big;
            else
                bad("format must be ascii, binary_little_endian or binary_big_endian");
            have_format = true;
        } else if (w[0] == "element") {
            Element e;
            if (w.size() != 3 || !parse_count(w[2], INT64_MAX, e.count))
                bad("expected 'element NAME COUNT' with COUNT >= 0");
            e.name = w[1];
            elements.push_back(e);
        } else if (w[0] == "property") {
            if (elements.empty()) bad("a 'property' line before any 'element' line");
            Property p;
            if (w.size() == 5 && w[1] == "list") {
                p.list = true;
                if (!parse_type(w[2], p.count_type) || !parse_type(w[3], p.type))
                    bad("unknown type in a list property (allowed: char, uchar, short, "
                        "ushort, int, uint, float, double, or int8 ... float64)");
                if (p.count_type == Type::F32 || p.count_type == Type::F64)
                    bad("a list's count must have an integer type");
                p.name = w[4];
            } else if (w.size() == 3 && w[1] != "list") {
                if (!parse_type(w[1], p.type))
                    bad("unknown property type (allowed: char, uchar, short, ushort, "
                        "int, "
                        "uint, float, double, or int8 ... float64)");
                p.name = w[2];
            } else {
                bad("expected 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
            }
            elements.back().properties.push_back(p);
        } else if (w[0] == "end_header") {
            if (!have_format) bad("end_header before a 'format' line");
            ended = true;
        } else {
            bad("expected comment, obj_info, format, element, property or end_header");
        }
    }
    if (!ended) fail(path, ": malformed PLY header: no end_header line");

    PolygonSoup soup;
    PlyBody body(path, data, at, format);
    for (const Element& e : elements) {
        if (e.count > 0 && e.properties.empty())
            fail(path, ": PLY element '", e.name, "' has items but no properties");
        const bool vertex = e.name == "vertex", face = e.name == "face";
        int xyz[3] = {-1, -1, -1};
        int indices = -1;
        for (size_t i = 0; i < e.properties.size(); ++i) {
            const Property& p = e.properties[i];
            for (int c = 0; c < 3; ++c)
                if (vertex && !p.list && p.name == std::string(1, char('x' + c)))
                    xyz[c] = int(i);
            if (face && p.list &&
                (p.name == "vertex_indices" || p.name == "vertex_index"))
                indices = int(i);
        }
        if (vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0))
            fail(path, ": PLY element 'vertex' needs the scalar properties x, y and z");
        if (face && indices < 0)
            fail(path,
                 ": PLY element 'face' needs a list property vertex_indices (or "
                 "vertex_index)");
        for (uint64_t item = 0; item < e.count; ++item) {
            const std::string where = "element '" + e.name + "' " + std::to_string(item);
            double point[3] = {0, 0, 0};
            for (size_t i = 0; i < e.properties.size(); ++i) {
                const Property& p = e.properties[i];
                if (!p.list) {
                    const double v = body.next(p.type, where);
                    for (int c = 0; c < 3; ++c)
                        if (int(i) == xyz[c]) point[c] = v;
                    continue;
                }
                const double n = body.next(p.count_type, where);
                if (!(n >= 0.0 && n <= double(kMaxFaceVertices)))
                    fail(path, ": ", where, ": a list of ", n, " values (allowed: 0 to ",
                         kMaxFaceVertices, ")");
                std::vector<std::size_t> polygon;
                for (uint64_t k = 0; k < uint64_t(n); ++k) {
                    const double v = body.next(p.type, where);
                    if (int(i) == indices)
                        polygon.push_back(index_of(v, path, where.c_str()));
                }
                if (int(i) == indices) soup.polygons.push_back(std::move(polygon));
            }
            if (vertex) soup.xyz.insert(soup.xyz.end(), point, point + 3);
            body.end_item(where);
        }
    }
    body.end_body();
    return soup;
}

PolygonSoup read_off(const std::string& path) {
    const std::string data = without_bom(read_all(path));
    // Lines without comments (from '#') and without blank lines, with their numbers.
    std::vector<std::pair<int, std::vector<std::string>>> lines;
    {
        std::istringstream in(data);
        std::string line;
        for (int n = 1; std::getline(in, line); ++n) {
            const size_t hash = line.find('#');
            if (hash != std::string::npos) line.resize(hash);
            std::vector<std::string> w = words_of(line);
            if (!w.empty()) lines.emplace_back(n, std::move(w));
        }
    }
    if (lines.empty()) fail(path, ": malformed OFF file: it is empty");
    std::vector<std::string> head = lines[0].second;
    const std::string& key = head[0];
    const size_t off = key.rfind("OFF");
    if (off == std::string::npos || off + 3 != key.size())
        fail(path, ": malformed OFF file, line ", lines[0].first,
             ": it must start with OFF (or COFF, NOFF, STOFF, ...)");
    for (char c : key.substr(0, off))
        if (!std::strchr("STCN", c))
            fail(path, ": OFF variant '", key,
                 "' is not supported (allowed: OFF with the prefixes ST, C, N)");
    head.erase(head.begin());
    if (!head.empty() && head[0] == "BINARY")
        fail(path, ": binary OFF is not supported (allowed: ASCII OFF)");
    size_t next = 1;
    if (head.empty()) {  // the counts are on the next line
        if (lines.size() < 2)
            fail(path, ": malformed OFF file: no vertex and face counts");
        head = lines[1].second;
        next = 2;
    }
    uint64_t nv = 0, nf = 0;
    if (head.size() < 2 || !parse_count(head[0], INT32_MAX, nv) ||
        !parse_count(head[1], INT32_MAX, nf))
        fail(path, ": malformed OFF file, line ", lines[next - 1].first,
             ": expected the vertex, face and edge counts (integers >= 0)");
    if (nv + nf > lines.size() - next)
        fail(path, ": malformed OFF file: it names ", nv, " vertices and ", nf,
             " faces but has ", lines.size() - next, " lines after its header");

    PolygonSoup soup;
    soup.xyz.reserve(size_t(3 * nv));
    for (uint64_t i = 0; i < nv; ++i) {
        const auto& [n, w] = lines[next + i];
        double v[3];
        if (w.size() < 3 || !parse_double(w[0], v[0]) || !parse_double(w[1], v[1]) ||
            !parse_double(w[2], v[2]))
            fail(path, ": malformed OFF file, line ", n, ": vertex ", i,
                 " needs three numbers x y z");
        soup.xyz.insert(soup.xyz.end(), v, v + 3);
    }
    next += size_t(nv);
    soup.polygons.reserve(size_t(nf));
    for (uint64_t f = 0; f < nf; ++f) {
        const auto& [n, w] = lines[next + f];
        uint64_t count = 0;
        if (!parse_count(w[0], kMaxFaceVertices, count) || w.size() < 1 + count)
            fail(path, ": malformed OFF file, line ", n, ": face ", f,
                 " needs its vertex count (0 to ", kMaxFaceVertices,
                 ") and that many vertex indices");
        std::vector<std::size_t> polygon;
        for (uint64_t k = 0; k < count; ++k) {
            uint64_t index = 0;
            if (!parse_count(w[1 + k], INT64_MAX, index))
                fail(path, ": malformed OFF file, line ", n, ": face ", f,
                     ": vertex index '", quoted(w[1 + k]),
                     "' is not allowed (allowed: integers >= 0)");
            if (index >= nv)
                fail(path, ": malformed OFF file, line ", n, ": face ", f,
                     ": vertex index ", index, " but the file has ", nv,
                     " vertices (counted from 0)");
            polygon.push_back(std::size_t(index));
        }
        soup.polygons.push_back(std::move(polygon));
    }
    return soup;
}

// --- STL ---------------------------------------------------------------------------

namespace {

// The triangle count of a binary STL header (0 for a file too short to hold one).
uint64_t stl_binary_count(const std::string& data) {
    if (data.size() < 84) return 0;
    uint32_t count = 0;  // little-endian, as the format has it
    for (int i = 3; i >= 0; --i) count = (count << 8) | uint8_t(data[80 + size_t(i)]);
    return count;
}

// Binary STL: an 80-byte header, a little-endian triangle count, then 50 bytes per
// triangle (a normal, three corners as floats, two bytes of attributes).
PolygonSoup read_binary_stl(const std::string& path, const std::string& data) {
    const uint64_t count = stl_binary_count(data);
    PolygonSoup soup;
    soup.xyz.reserve(size_t(9 * count));
    soup.polygons.reserve(size_t(count));
    for (uint64_t t = 0; t < count; ++t) {
        const char* corners = data.data() + 84 + 50 * t + 12;  // past the normal
        for (int k = 0; k < 9; ++k) {
            unsigned char b[4];
            std::memcpy(b, corners + 4 * k, 4);
            uint32_t bits = 0;
            for (int i = 3; i >= 0; --i) bits = (bits << 8) | b[i];
            float v;
            std::memcpy(&v, &bits, 4);
            soup.xyz.push_back(double(v));
        }
        soup.polygons.push_back({size_t(3 * t), size_t(3 * t + 1), size_t(3 * t + 2)});
    }
    return soup;
}

std::string lower(std::string w) {
    for (char& c : w) c = char(std::tolower(static_cast<unsigned char>(c)));
    return w;
}

// ASCII STL: one or more "solid NAME ... endsolid NAME" blocks of
//   facet normal NX NY NZ / outer loop / vertex X Y Z (3 or more) / endloop / endfacet,
// read word by word (keywords in any case), so a misplaced word is named with its line.
PolygonSoup read_ascii_stl(const std::string& path, const std::string& text) {
    enum class In { Nothing, Solid, Facet, Loop, LoopEnded };
    static const char* const kExpected[] = {"'solid'", "'facet' or 'endsolid'",
                                            "'outer loop'", "'vertex X Y Z' or 'endloop'",
                                            "'endfacet'"};
    PolygonSoup soup;
    In in = In::Nothing;
    int solid_line = 0, facet_line = 0;  // where the solid and the facet being read begin
    std::vector<std::size_t> polygon;
    std::istringstream lines(text);
    std::string line;
    for (int n = 1; std::getline(lines, line); ++n) {
        const std::vector<std::string> w = words_of(line);
        auto bad = [&](const auto&... why) {
            fail(path, ": malformed ASCII STL file, line ", n, ": ", why...);
        };
        for (size_t i = 0; i < w.size();) {
            const std::string key = lower(w[i]);
            auto unexpected = [&] {
                bad("expected ", kExpected[int(in)], ", got '", quoted(w[i]), "'");
            };
            if (key == "solid" && in == In::Nothing) {
                in = In::Solid, solid_line = n;
                i = w.size();  // the rest of the line is the solid's name
            } else if (key == "endsolid" && in == In::Solid) {
                in = In::Nothing;
                i = w.size();
            } else if (key == "facet" && in == In::Solid) {
                in = In::Facet, facet_line = n;
                ++i;
                if (i < w.size() && lower(w[i]) == "normal")
                    i = std::min(i + 4, w.size());
            } else if (key == "outer" && in == In::Facet) {
                if (i + 1 >= w.size() || lower(w[i + 1]) != "loop") unexpected();
                in = In::Loop;
                i += 2;
            } else if (key == "vertex" && in == In::Loop) {
                double v[3];
                if (i + 3 >= w.size() || !parse_double(w[i + 1], v[0]) ||
                    !parse_double(w[i + 2], v[1]) || !parse_double(w[i + 3], v[2]))
                    bad("a vertex needs three numbers x y z");
                if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
                    bad("a vertex is not finite");
                polygon.push_back(soup.xyz.size() / 3);
                soup.xyz.insert(soup.xyz.end(), v, v + 3);
                i += 4;
            } else if (key == "endloop" && in == In::Loop) {
                if (polygon.size() < 3)
                    bad("a facet needs at least 3 vertices, this one has ",
                        polygon.size());
                in = In::LoopEnded;
                ++i;
            } else if (key == "endfacet" && in == In::LoopEnded) {
                soup.polygons.push_back(std::move(polygon));
                polygon.clear();
                in = In::Solid;
                ++i;
            } else {
                unexpected();
            }
        }
    }
    if (in != In::Nothing)
        fail(path, ": malformed ASCII STL file: it ends inside the ",
             in == In::Solid ? "solid" : "facet", " begun on line ",
             in == In::Solid ? solid_line : facet_line, " (expected ", kExpected[int(in)],
             "): truncated?");
    return soup;
}

}  // namespace

PolygonSoup read_stl(const std::string& path) {
    const std::string data = read_all(path);
    // Binary if its size is the one its header's count gives (a binary header may start
    // with "solid", as an ASCII file does); else ASCII if it starts with "solid" and has
    // no NUL byte in its first kilobyte (binary headers and counts usually do).
    const uint64_t count = stl_binary_count(data);
    if (data.size() >= 84 && data.size() == 84 + 50 * count)
        return read_binary_stl(path, data);
    const std::string text = without_bom(data);
    const size_t first = text.find_first_not_of(" \t\r\n");
    const bool ascii =
        first != std::string::npos && text.size() - first >= 5 &&
        std::equal(text.begin() + long(first), text.begin() + long(first) + 5, "solid",
                   [](char a, char b) { return std::tolower((unsigned char)a) == b; }) &&
        text.find('\0') >= 1024;
    if (ascii) return read_ascii_stl(path, text);
    if (data.size() < 84)
        fail(path, ": malformed STL file: ", data.size(),
             " bytes, neither ASCII (which starts with 'solid') nor binary (84 bytes of "
             "header and triangle count at least)");
    fail(path, ": malformed binary STL file: its header counts ", count,
         " triangles, which take ", 84 + 50 * count, " bytes, but the file has ",
         data.size(), " bytes");
}

// --- OBJ ---------------------------------------------------------------------------

namespace {

// OBJ keywords that carry nothing a polygon mesh needs: read and ignored.
bool ignored_obj_keyword(const std::string& k) {
    static const char* const kIgnored[] = {
        "vt",    "vn",       "vp",       "l",          "p",         "o",      "g",
        "s",     "mg",       "usemtl",   "mtllib",     "maplib",    "usemap", "lod",
        "bevel", "c_interp", "d_interp", "shadow_obj", "trace_obj", "csh",    "bsp",
        "bzp",   "cdc",      "cdp",      "res"};  // the last five: superseded
    return std::find_if(std::begin(kIgnored), std::end(kIgnored),
                        [&](const char* w) { return k == w; }) != std::end(kIgnored);
}

// Free-form geometry (curves and surfaces), which has no polygons to read.
bool freeform_obj_keyword(const std::string& k) {
    static const char* const kFreeform[] = {
        "cstype", "deg",  "bmat", "step", "curv", "curv2", "surf",  "parm",
        "trim",   "hole", "scrv", "sp",   "end",  "con",   "ctech", "stech"};
    return std::find_if(std::begin(kFreeform), std::end(kFreeform),
                        [&](const char* w) { return k == w; }) != std::end(kFreeform);
}

}  // namespace

PolygonSoup read_obj(const std::string& path) {
    const std::string data = without_bom(read_all(path));
    PolygonSoup soup;
    std::istringstream in(data);
    std::vector<int> face_lines;
    bool freeform = false;  // the line of each face, for the indices checked last
    std::string line;
    auto next_line = [&](std::string& l) {
        if (!std::getline(in, l)) return false;
        if (!l.empty() && l.back() == '\r') l.pop_back();
        return true;
    };
    int n = 0;
    while (next_line(line)) {
        const int first = ++n;
        // A line ending in '\' goes on on the next, unless the '\' is in a comment (a
        // Windows path: "# from C:\models\").
        auto goes_on = [](const std::string& l) {
            return !l.empty() && l.back() == '\\' && l.find('#') == std::string::npos;
        };
        for (std::string more; goes_on(line) && next_line(more); ++n)
            line.back() = ' ', line += more;
        const size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        const std::vector<std::string> w = words_of(line);
        if (w.empty()) continue;
        auto bad = [&](const auto&... why) {
            fail(path, ": malformed OBJ file, line ", first, ": ", why...);
        };
        const std::string& key = w[0];
        if (key == "v") {
            double v[3] = {0.0, 0.0, 0.0};
            if (w.size() < 4 || !parse_double(w[1], v[0]) || !parse_double(w[2], v[1]) ||
                !parse_double(w[3], v[2]))
                bad("vertex ", soup.xyz.size() / 3 + 1, " needs three numbers x y z");
            if (w.size() > 8)  // x y z, then w or r g b (or w r g b)
                bad("vertex ", soup.xyz.size() / 3 + 1, " has ", w.size() - 1,
                    " numbers (at most 7: x y z, then w or r g b; a file whose lines end "
                    "in a bare CR?)");
            if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
                bad("vertex ", soup.xyz.size() / 3 + 1, " is not finite");
            for (double c : v)
                if (std::abs(c) > double(std::numeric_limits<float>::max()))
                    bad("vertex ", soup.xyz.size() / 3 + 1,
                        " does not fit in single precision (|x| < 3.4e38)");
            soup.xyz.insert(soup.xyz.end(), v, v + 3);
        } else if (key == "f" || key == "fo") {
            if (w.size() - 1 > kMaxFaceVertices)
                bad("a face has more than ", kMaxFaceVertices, " vertices");
            const uint64_t defined = soup.xyz.size() / 3;
            std::vector<std::size_t> polygon;
            for (size_t k = 1; k < w.size(); ++k) {
                // v, v/vt, v/vt/vn or v//vn: the vertex index is the part before '/'.
                const std::string v = w[k].substr(0, w[k].find('/'));
                char* end = nullptr;
                errno = 0;
                const long long i = std::strtoll(v.c_str(), &end, 10);
                if (v.empty() || *end != '\0' || errno == ERANGE || i == 0)
                    bad("vertex index '", quoted(w[k]),
                        "' is not allowed (allowed: non-zero integers; 1 is the first "
                        "vertex, -1 the last one read)");
                if (i < 0 && uint64_t(-(i + 1)) >= defined)
                    bad("vertex index ", i, " reaches back before the first vertex (",
                        defined, " read so far)");
                polygon.push_back(i > 0 ? std::size_t(i - 1)
                                        : std::size_t(defined - uint64_t(-(i + 1)) - 1));
            }
            if (polygon.size() < 3)
                bad("a face needs at least 3 vertices, this one has ", polygon.size());
            soup.polygons.push_back(std::move(polygon));
            face_lines.push_back(first);
        } else if (freeform_obj_keyword(key)) {
            freeform = true;  // curves and surfaces: only the polygons are read
        } else if (key == "call") {
            bad("'call' (another file's geometry) is not supported: merge the files");
        } else if (!ignored_obj_keyword(key)) {
            bad("unknown keyword '", quoted(key), "' (a mesh needs 'v' and 'f' lines)");
        }
    }
    if (freeform && soup.polygons.empty())
        fail(path, ": the OBJ file has free-form geometry (curves, surfaces) and no ",
             "polygons: not supported (allowed: polygons, 'f' lines)");
    const uint64_t vertices = soup.xyz.size() / 3;
    for (size_t f = 0; f < soup.polygons.size(); ++f)
        for (std::size_t i : soup.polygons[f])
            if (i >= vertices)
                fail(path, ": malformed OBJ file, line ", face_lines[f],
                     ": vertex index ", i + 1, " but the file has ", vertices,
                     " vertices");
    return soup;
}

}  // namespace sss

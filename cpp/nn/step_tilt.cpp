#include "nn/step_tilt.h"

#include <cmath>

#include "core/check.h"
#include "core/files.h"
#include "io/json_fields.h"

namespace sss {

using namespace json_fields;

namespace {

// Node coordinate of x between increasing nodes: index i and fraction t in [0, 1],
// clamped at both ends (model.glsl's tilt_at does the same).
void locate(const std::vector<float>& nodes, float x, size_t* i, float* t) {
    const size_t n = nodes.size();
    if (n == 1 || !(x > nodes[0])) {
        *i = 0, *t = 0.f;
        return;
    }
    size_t k = 0;
    while (k + 2 < n && x >= nodes[k + 1]) ++k;
    *i = k;
    *t = std::min(1.f, (x - nodes[k]) / (nodes[k + 1] - nodes[k]));
}

std::vector<float> nodes_of(const json& j, const Field& f, double lo, double hi,
                            bool open, const char* allowed) {
    if (!j.is_array() || j.empty() || j.size() > 64)
        f.error("expected an array of 1 to 64 numbers, got ", described(j));
    std::vector<float> v;
    for (size_t i = 0; i < j.size(); ++i) {
        const double x = number(j[i], f.at(i));
        if (open ? !(x > lo && x < hi) : !(x >= lo && x <= hi))
            f.at(i).error("value ", show(j[i]), " is not allowed (allowed: ", allowed,
                          ")");
        if (i > 0 && !(float(x) > v.back()))
            f.at(i).error("value ", show(j[i]),
                          " is not above the node before it (nodes must increase)");
        v.push_back(float(x));
    }
    return v;
}

std::vector<float> table_of(const json& j, const Field& f, size_t rows, size_t cols) {
    if (!j.is_array() || j.size() != rows)
        f.error("expected an array of ", rows, " rows (one per node of g), got ",
                described(j));
    std::vector<float> v;
    for (size_t r = 0; r < rows; ++r) {
        if (!j[r].is_array() || j[r].size() != cols)
            f.at(r).error("expected an array of ", cols,
                          " numbers (one per node of sigma), got ", described(j[r]));
        for (size_t c = 0; c < cols; ++c)
            v.push_back(float(number(j[r][c], f.at(r).at(c))));
    }
    return v;
}

}  // namespace

void StepTilt::at(float sigma, float gv, float* a_out, float* b_out) const {
    *a_out = *b_out = 0.f;
    if (empty()) return;
    size_t i, k;
    float t, u;
    locate(log_sigma, std::log(sigma), &i, &t);
    locate(g, gv, &k, &u);
    const size_t ns = log_sigma.size(), i1 = std::min(i + 1, ns - 1),
                 k1 = std::min(k + 1, g.size() - 1);
    auto lerp2 = [&](const std::vector<float>& v) {
        const float lo = v[k * ns + i] + t * (v[k * ns + i1] - v[k * ns + i]);
        const float hi = v[k1 * ns + i] + t * (v[k1 * ns + i1] - v[k1 * ns + i]);
        return lo + u * (hi - lo);
    };
    *a_out = lerp2(a);
    *b_out = lerp2(b);
}

StepTilt parse_step_tilt(const std::string& text, const std::string& source) {
    json j = parse_json(text, source);
    Field root{source, ""};
    if (!j.is_object()) root.error("expected a JSON object, got ", type_name(j));
    check_format(j, root, kTiltFormat, kTiltFormatVersion, "a tilt file");
    check_keys(j, root,
               {"format", "format_version", "sigma", "g", "a", "b", "calibration"});

    StepTilt t;
    t.source = source;
    std::vector<float> sigma = nodes_of(require(j, "sigma", root), root.at("sigma"), 0.0,
                                        1e30, true, "0 < sigma < 1e30");
    for (float s : sigma) t.log_sigma.push_back(std::log(s));
    t.g = nodes_of(require(j, "g", root), root.at("g"), -1.0, 1.0, true, "-1 < g < 1");
    t.a = table_of(require(j, "a", root), root.at("a"), t.g.size(), sigma.size());
    t.b = table_of(require(j, "b", root), root.at("b"), t.g.size(), sigma.size());
    for (size_t k = 0; k < t.a.size(); ++k) {
        const float s = std::abs(t.a[k]) + std::abs(t.b[k]);
        if (!(s <= kTiltMaxSum)) {
            const size_t r = k / sigma.size(), c = k % sigma.size();
            root.at("a").at(r).at(c).error(
                "|a| + |b| = ", s, " at sigma ", sigma[c], ", g ", t.g[r],
                " is not allowed (allowed: at most ", kTiltMaxSum, ")");
        }
    }
    return t;
}

StepTilt load_step_tilt(const std::string& path) {
    return parse_step_tilt(read_input_file(path, "tilt file"), path);
}

}  // namespace sss

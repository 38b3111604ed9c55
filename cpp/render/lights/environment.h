// Environment: radiance arriving from every direction, met by every ray that leaves the
// scene. Either constant (`radiance`: value = that radiance, scalar = int bits of -1), or
// an equirectangular map (`map`, an EXR or HDR file twice as wide as high) times `scale`
// (value = scale), turned by `rotate_deg` (a, b, c = the rotation's columns R e_x, R e_y,
// R e_z: a world direction w has map-frame coordinates (a.w, b.w, c.w)), kept in the
// scene's table of floats at the offset whose int bits scalar holds.
//
// The map follows Mitsuba 3's `envmap` (docs/scene-format.md): in the map's frame +y is
// up; a direction of travel v has u = atan2(v.x, -v.z) / 2 pi (mod 1) and v = acos(v.y) /
// pi; pixel (x, y) is the radiance at u = (x + 1/2) / W, v = y / (H - 1) (row 0 is the
// zenith, the last row the nadir), bilinear in between and periodic in u.
//
// Sampling: a piecewise-constant density over the map's W x (H - 1) cells between pixel
// centres, each weighted by its largest corner (so that every direction with radiance has
// density) times its solid angle, drawn row by the marginal then column by the
// conditional distribution (pbrt's 2D distribution); constant: uniform on the sphere.
#ifndef SSS_RENDER_LIGHTS_ENVIRONMENT_H
#define SSS_RENDER_LIGHTS_ENVIRONMENT_H

#include "render/lights/light.h"
#include "shared/sampling.h"

#ifdef __cplusplus
#include <cmath>
#include <filesystem>

#include "core/files.h"
#include "geometry/mesh.h"
#include "io/image_input.h"
#endif

#ifdef __cplusplus
namespace sss {
#endif

// The table at offset o: W, H, then the texels (H rows of W RGB, row 0 the zenith), the
// marginal CDF over the H - 1 cell rows (H entries, 0 ... 1) and per cell row the
// conditional CDF over its W cells (W + 1 entries each).
SSS_FN int env_texel(int o, int W, int x, int y) { return o + 2 + 3 * (y * W + x); }
SSS_FN int env_marginal(int o, int W, int H) { return o + 2 + 3 * W * H; }
SSS_FN int env_conditional(int o, int W, int H, int row) {
    return env_marginal(o, W, H) + H + row * (W + 1);
}

// The index k in [0, n) with cdf[k] <= u < cdf[k + 1] (cdf at `at`, n + 1 entries from 0
// to 1, u in [0, 1)): never a bin of probability 0.
SSS_FN int env_find(int at, int n, float u SSS_LIGHT_FLOATS_PARAM) {
    int lo = 0, hi = n;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (SSS_LIGHT_FLOAT(at + mid) <= u)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

// The map's coordinates of a world direction of travel w: x in [0, W), y in [0, H - 1].
SSS_FN Vec3 env_map_xy(LightData l, Vec3 w, int W, int H) {
    Vec3 v = Vec3(dot(l.a, w), dot(l.b, w), dot(l.c, w));
    float u = atan2(v.x, -v.z) * (0.5f / kPi);
    u = u - floor(u);
    float vv = acos(clamp(v.y, -1.f, 1.f)) * (1.f / kPi);
    float x = u * float(W) - 0.5f;
    x = x - float(W) * floor(x / float(W));  // periodic: [0, W) (W itself by rounding)
    if (x >= float(W)) x = 0.f;
    return Vec3(x, min(vv * float(H - 1), float(H - 1)), 0.f);
}

// The map's radiance (times scale) at map coordinates (x, y), bilinear.
SSS_FN Vec3 env_radiance(LightData l, int o, int W, int H, float x,
                         float y SSS_LIGHT_FLOATS_PARAM) {
    int x0 = min(int(x), W - 1), y0 = min(int(y), H - 2);
    int x1 = x0 + 1 == W ? 0 : x0 + 1;
    float fx = x - float(x0), fy = y - float(y0);
    Vec3 sum = Vec3(0.f, 0.f, 0.f);
    for (int c = 0; c < 3; ++c) {
        float v00 = SSS_LIGHT_FLOAT(env_texel(o, W, x0, y0) + c);
        float v10 = SSS_LIGHT_FLOAT(env_texel(o, W, x1, y0) + c);
        float v01 = SSS_LIGHT_FLOAT(env_texel(o, W, x0, y0 + 1) + c);
        float v11 = SSS_LIGHT_FLOAT(env_texel(o, W, x1, y0 + 1) + c);
        sum[c] = (1.f - fy) * ((1.f - fx) * v00 + fx * v10) +
                 fy * ((1.f - fx) * v01 + fx * v11);
    }
    return sum * l.value;
}

// The solid-angle density of sampling the direction at map coordinates (x, y).
SSS_FN float env_pdf(int o, int W, int H, float x, float y SSS_LIGHT_FLOATS_PARAM) {
    int i = min(int(x), W - 1), j = min(int(y), H - 2);
    int m = env_marginal(o, W, H), c = env_conditional(o, W, H, j);
    float p_row = SSS_LIGHT_FLOAT(m + j + 1) - SSS_LIGHT_FLOAT(m + j);
    float p_col = SSS_LIGHT_FLOAT(c + i + 1) - SSS_LIGHT_FLOAT(c + i);
    float sin_theta = sin(kPi * y / float(H - 1));
    if (!(sin_theta > 0.f)) return 0.f;
    // Density in (u, v): p_row p_col / (cell area 1 / (W (H - 1))); d omega = 2 pi^2
    // sin(theta) du dv.
    return p_row * p_col * float(W) * float(H - 1) / (2.f * kPi * kPi * sin_theta);
}

SSS_FN LightSample environment_light_sample(LightData l, Vec3 p, float u1,
                                            float u2 SSS_LIGHT_FLOATS_PARAM) {
    LightSample s = no_light_sample();
    s.dist = kInf;
    int o = floatBitsToInt(l.scalar);
    if (o < 0) {  // constant
        s.w = sample_uniform_sphere(u1, u2);
        s.L = l.value;
        s.pdf = uniform_sphere_pdf();
        return s;
    }
    int W = int(SSS_LIGHT_FLOAT(o)), H = int(SSS_LIGHT_FLOAT(o + 1));
    int j = env_find(env_marginal(o, W, H), H - 1, u2 SSS_LIGHT_FLOATS_ARG);
    int m = env_marginal(o, W, H);
    float t2 = (u2 - SSS_LIGHT_FLOAT(m + j)) /
               (SSS_LIGHT_FLOAT(m + j + 1) - SSS_LIGHT_FLOAT(m + j));
    int c = env_conditional(o, W, H, j);
    int i = env_find(c, W, u1 SSS_LIGHT_FLOATS_ARG);
    float t1 = (u1 - SSS_LIGHT_FLOAT(c + i)) /
               (SSS_LIGHT_FLOAT(c + i + 1) - SSS_LIGHT_FLOAT(c + i));
    float x = float(i) + t1, y = float(j) + t2;
    float theta = kPi * y / float(H - 1);
    float phi = 2.f * kPi * (x + 0.5f) / float(W);
    float st = sin(theta);
    Vec3 v = Vec3(st * sin(phi), cos(theta), -st * cos(phi));  // map frame
    s.w = normalize(l.a * v.x + l.b * v.y + l.c * v.z);
    // Radiance and density from the direction itself, as a ray along it would see them.
    Vec3 xy = env_map_xy(l, s.w, W, H);
    s.pdf = env_pdf(o, W, H, xy.x, xy.y SSS_LIGHT_FLOATS_ARG);
    if (!(s.pdf > 0.f)) return no_light_sample();
    s.L = env_radiance(l, o, W, H, xy.x, xy.y SSS_LIGHT_FLOATS_ARG);
    return s;
}

SSS_FN LightEval environment_light_eval(LightData l, Vec3 p, Vec3 w, float t,
                                        Vec3 n SSS_LIGHT_FLOATS_PARAM) {
    LightEval e;
    int o = floatBitsToInt(l.scalar);
    if (o < 0) {
        e.L = l.value;
        e.pdf = uniform_sphere_pdf();
        return e;
    }
    int W = int(SSS_LIGHT_FLOAT(o)), H = int(SSS_LIGHT_FLOAT(o + 1));
    Vec3 xy = env_map_xy(l, w, W, H);
    e.L = env_radiance(l, o, W, H, xy.x, xy.y SSS_LIGHT_FLOATS_ARG);
    e.pdf = env_pdf(o, W, H, xy.x, xy.y SSS_LIGHT_FLOATS_ARG);
    return e;
}

#ifdef __cplusplus
namespace environment_map {

// Where the marginal and a row's conditional CDF start in a table (offset 0).
inline int marginal_offset(int W, int H) { return env_marginal(0, W, H); }
inline int conditional_offset(int W, int H, int row) {
    return env_conditional(0, W, H, row);
}

// Appends the table of an environment map (image rows of `width` RGB texels) to `floats`
// and returns its offset. Checks nothing: the parser has.
inline int append_table(const std::vector<float>& rgb, int W, int H,
                        std::vector<float>& floats) {
    const int o = int(floats.size());
    floats.push_back(float(W));
    floats.push_back(float(H));
    floats.insert(floats.end(), rgb.begin(), rgb.end());
    // Cell (i, j) spans pixels i, i + 1 (mod W) of rows j, j + 1; its weight is its
    // largest corner channel times its solid angle (cos theta_j - cos theta_{j+1}, times
    // 2 pi / W).
    std::vector<double> row_sum(size_t(H - 1), 0.0);
    std::vector<std::vector<double>> cell(size_t(H - 1), std::vector<double>(size_t(W)));
    auto texel_max = [&](int x, int y) {
        const float* t = &rgb[size_t(3) * (size_t(y) * W + x)];
        return double(std::max({t[0], t[1], t[2]}));
    };
    for (int j = 0; j + 1 < H; ++j) {
        const double band =
            std::cos(M_PI * j / (H - 1)) - std::cos(M_PI * (j + 1) / (H - 1));
        for (int i = 0; i < W; ++i) {
            const int i1 = (i + 1) % W;
            const double m = std::max({texel_max(i, j), texel_max(i1, j),
                                       texel_max(i, j + 1), texel_max(i1, j + 1)});
            cell[j][i] = m * band;
            row_sum[j] += cell[j][i];
        }
    }
    double total = 0.0;
    for (double r : row_sum) total += r;
    // An all-black map: sample uniformly in (u, v) (it has no radiance to miss).
    auto cdf = [&](const std::vector<double>& w, double sum) {
        double acc = 0.0;
        floats.push_back(0.f);
        for (size_t k = 0; k < w.size(); ++k) {
            acc += sum > 0.0 ? w[k] : 1.0;
            floats.push_back(
                k + 1 == w.size() ? 1.f : float(acc / (sum > 0.0 ? sum : w.size())));
        }
    };
    cdf(row_sum, total);
    for (int j = 0; j + 1 < H; ++j) cdf(cell[j], row_sum[j]);
    return o;
}

}  // namespace environment_map

inline LightType environment_light_type() {
    using namespace json_fields;
    LightType t;
    t.name = "environment";
    t.environment = true;
    t.optional = {"radiance", "map", "scale", "rotate_deg"};
    t.parse = [](const json& j, const Field& f, const LightContext& ctx) {
        LightData l{};
        if (j.contains("radiance") == j.contains("map"))
            f.error(
                "give exactly one of 'radiance' (a constant) or 'map' (an image file)");
        for (const char* key : {"scale", "rotate_deg"})
            if (j.contains(key) && !j.contains("map"))
                f.at(key).error("applies to a 'map' only");
        if (j.contains("radiance")) {
            l.value = light_fields::radiometric(j, f, "radiance");
            l.scalar = intBitsToFloat(-1);
            l.a = Vec3(1.f, 0.f, 0.f), l.b = Vec3(0.f, 1.f, 0.f),
            l.c = Vec3(0.f, 0.f, 1.f);
            return l;
        }
        const json& m = j["map"];
        const Field fm = f.at("map");
        if (!m.is_string() || m.get<std::string>().empty())
            fm.error("expected an image file path string (.exr), got ", show(m));
        std::filesystem::path path(m.get<std::string>());
        if (path.is_relative()) path = std::filesystem::path(ctx.base_dir) / path;
        std::string ext = path.extension().string();
        for (char& ch : ext) ch = char(std::tolower(ch));
        // Our image reader takes .exr and .png, and a .png is not linear radiance.
        if (ext != ".exr")
            fm.error("'", path.string(), "': unsupported image format '", ext,
                     "' (allowed: .exr, linear radiance)");
        if (ctx.inputs) ctx.inputs->push_back(path.string());
        ImageData img;
        try {
            check_input_file(path.string(), "environment map");
            if (!image_reader())
                fail("this program cannot read images (no image reader installed)");
            img = image_reader()(path.string());
        } catch (const std::exception& e) {
            fm.error(e.what());
        }
        if (img.height < 2 || img.width != 2 * img.height)
            fm.error("'", path.string(), "' is ", img.width, " x ", img.height,
                     " pixels (allowed: an equirectangular map twice as wide as high, at "
                     "least "
                     "4 x 2)");
        if (int64_t(img.width) * img.height > (int64_t(1) << 26))
            fm.error("'", path.string(), "' has ", int64_t(img.width) * img.height,
                     " pixels (allowed: at most 67,108,864, e.g. 8192 x 4096)");
        // A light's radiance is at most 1e30 (light.h), the map's pixels times scale too:
        // past it the sampling tables and the image overflow float (Inf pixels).
        constexpr double kMaxRadiance = 1e30;
        std::vector<float> rgb(size_t(3) * img.width * img.height);
        float brightest = 0.f;
        size_t brightest_px = 0;
        for (size_t px = 0; px < size_t(img.width) * img.height; ++px)
            for (int c = 0; c < 3; ++c) {
                const float v =
                    img.pixels[px * img.channels + size_t(std::min(c, img.channels - 1))];
                if (!(v >= 0.f) || !(v <= kMaxRadiance))
                    fm.error("'", path.string(), "': pixel (", px % img.width, ", ",
                             px / img.width, ") channel ", c, " is ", v,
                             " (allowed: finite radiance from 0 to 1e30)");
                if (v > brightest) brightest = v, brightest_px = px;
                rgb[3 * px + c] = v;
            }
        const float scale = j.contains("scale")
                                ? float(number_in(j["scale"], f.at("scale"), 0.0, 1e30,
                                                  "a number in [0, 1e30]"))
                                : 1.f;
        // against 1e30 as a float, as scale and the pixels are: 1e30 times a pixel of 1,
        // both allowed, is allowed (the double 1e30 is below the float's 1e30)
        if (double(brightest) * scale > double(float(kMaxRadiance)))
            f.at("scale").error(scale, " times the map's brightest pixel, ", brightest,
                                " at (", brightest_px % img.width, ", ",
                                brightest_px / img.width, ") of '", path.string(),
                                "', is ", double(brightest) * scale,
                                " (allowed: a radiance of at most 1e30)");
        l.value = Vec3(scale);
        Transform rot;
        if (j.contains("rotate_deg"))
            rot.rotate_deg = point3(j["rotate_deg"], f.at("rotate_deg"));
        l.a = rot.apply(Vec3d(1, 0, 0)).to_float();
        l.b = rot.apply(Vec3d(0, 1, 0)).to_float();
        l.c = rot.apply(Vec3d(0, 0, 1)).to_float();
        SSS_CHECK(ctx.floats != nullptr);
        l.scalar = intBitsToFloat(
            environment_map::append_table(rgb, img.width, img.height, *ctx.floats));
        return l;
    };
    t.mitsuba = [](const json& j) {
        if (j.contains("radiance"))
            return json{{"type", "constant"},
                        {"radiance", light_fields::mitsuba_rgb(j["radiance"])}};
        Transform rot;
        if (j.contains("rotate_deg"))
            rot.rotate_deg =
                Vec3d(j["rotate_deg"][0].get<double>(), j["rotate_deg"][1].get<double>(),
                      j["rotate_deg"][2].get<double>());
        json m = json::array();
        const Vec3d cols[3] = {rot.apply(Vec3d(1, 0, 0)), rot.apply(Vec3d(0, 1, 0)),
                               rot.apply(Vec3d(0, 0, 1))};
        for (int r = 0; r < 3; ++r)
            m.push_back({cols[0][r], cols[1][r], cols[2][r], 0.0});
        m.push_back({0.0, 0.0, 0.0, 1.0});
        return json{{"type", "envmap"},
                    {"filename", j["map"]},
                    {"scale", j.value("scale", 1.0)},
                    {"to_world", {{"$matrix", m}}}};
    };
    return t;
}
}  // namespace sss
#endif

#endif  // SSS_RENDER_LIGHTS_ENVIRONMENT_H

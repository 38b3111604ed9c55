#include "render/scene.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <variant>

#include "core/check.h"
#include "core/files.h"
#include "io/json_fields.h"
#include "render/medium_presets.h"
#include "shared/ray_offset.h"

namespace sss {

namespace {

using json = nlohmann::json;

using namespace json_fields;

// The camera's largest distance from the render frame's origin (parse_camera says why).
constexpr double kMaxCameraDistance = 1e17;

// `frame`: where the render frame's origin lies (SceneDesc::origin); positions are
// stored relative to it.
Camera parse_camera(const json& j, const Field& f, Vec3d frame) {
    check_keys(j, f, {"origin", "target", "up", "fov", "width", "height"});
    Camera c;
    const Vec3d origin = point3(require(j, "origin", f), f.at("origin"));
    const Vec3d target = point3(require(j, "target", f), f.at("target"));
    c.origin = (origin - frame).to_float();
    c.target = (target - frame).to_float();
    if (j.contains("up")) c.up = nonzero_vec3(j["up"], f.at("up"));
    c.fov = float(number_in(require(j, "fov", f), f.at("fov"), 1e-3, 179.0,
                            "degrees in [0.001, 179]"));
    c.width =
        int(integer_in(require(j, "width", f), f.at("width"), 1, 16384, "1 to 16384"));
    c.height =
        int(integer_in(require(j, "height", f), f.at("height"), 1, 16384, "1 to 16384"));
    if (int64_t(c.width) * c.height > (int64_t(1) << 26))
        f.error("resolution ", c.width, "x", c.height,
                " is too large (at most 67,108,864 pixels)");
    // A camera ray starts at the camera where it misses the shapes, and Embree aborts on
    // a ray whose origin has a coordinate past 1.8e18 (its FLT_LARGE); the start moves at
    // most twice the camera's distance along the ray (Scene::camera_ray_start).
    const double distance = length(origin - frame);
    if (!(distance <= kMaxCameraDistance))
        f.at("origin").error("lies ", distance,
                             " from the centre of the media's bounds (allowed: at most ",
                             kMaxCameraDistance, ", where single-precision rays start)");
    // The direction in double: its float length overflows past 1e19
    const Vec3d along = target - origin;
    const double len = length(along);
    if (!(len > 0.0) || !(c.target != c.origin))
        f.at("target").error("target equals origin");
    const Vec3 forward =
        Vec3(float(along.x / len), float(along.y / len), float(along.z / len));
    if (!(length(cross(normalize(forward), unit_normal(c.up))) > 1e-4f))
        f.at("up").error("value [", c.up.x, ", ", c.up.y, ", ", c.up.z,
                         "] is parallel to the viewing direction",
                         j.contains("up") ? "" : " (up defaults to [0, 1, 0])");
    return c;
}

// The entry of a type registry (light_types(), boundary_kinds()) that j's "type" names,
// with the keys j may have: its own and "type".
template <class Kind>
const Kind& kind_named(const std::vector<Kind>& kinds, const json& j, const Field& f) {
    if (!j.is_object()) f.error("expected an object, got ", show(j));
    const json& type = require(j, "type", f);
    if (!type.is_string()) f.at("type").error("expected a string, got ", described(type));
    std::string names;
    for (const Kind& k : kinds) {
        if (type.get<std::string>() == k.name) return k;
        names += std::string(names.empty() ? "" : ", ") + "\"" + k.name + "\"";
    }
    f.at("type").error("value ", show(type), " is not allowed (allowed: ", names, ")");
}

Boundary parse_boundary(const json& j, const Field& f) {
    const BoundaryKind* kind = &kind_named(boundary_kinds(), j, f);
    std::vector<const char*> keys{"type"};
    keys.insert(keys.end(), kind->keys.begin(), kind->keys.end());
    check_keys(j, f, keys);
    Boundary b;
    static_cast<BoundaryData&>(b) = kind->parse(j, f);
    b.type = kind->id;
    // Between equal indices there is no interface, whatever its roughness: light passes
    // straight, with no reflection. That is the index-matched boundary (the default); the
    // rough BSDF's half vector wi + wo vanishes there (NaN pixels). So is an index within
    // kIorIndexMatched of 1 (boundaries/dielectric.h says why).
    if (std::string(b.kind().name) == "dielectric" &&
        std::abs(b.x - 1.f) <= kIorIndexMatched)
        return Boundary();
    return b;
}

// The medium j's phase function: its "phase" object, or Henyey-Greenstein with its "g"
// (the shorthand the scene files use most).
Phase parse_phase(const json& j, const Field& f) {
    if (j.contains("g") && j.contains("phase"))
        f.at("phase").error("give either g (Henyey-Greenstein) or phase, not both");
    Phase p;
    if (j.contains("phase")) {
        const json& pj = j["phase"];
        const Field pf = f.at("phase");
        const PhaseKind& kind = kind_named(phase_kinds(), pj, pf);
        std::vector<const char*> keys{"type"};
        keys.insert(keys.end(), kind.keys.begin(), kind.keys.end());
        check_keys(pj, pf, keys);
        static_cast<PhaseData&>(p) = kind.parse(pj, pf);
        p.type = kind.id;
    } else {
        const PhaseKind& hg = kind_named(phase_kinds(), json{{"type", "hg"}}, f);
        static_cast<PhaseData&>(p) = hg.parse(j, f);
        p.type = hg.id;
    }
    return p;
}

// A medium is stated in exactly one of these ways (docs/scene-format.md, "Ways to state a
// medium"), each coefficient then multiplied by "scale".
Medium parse_medium(const json& j, const Field& f) {
    check_keys(j, f,
               {"sigma_t", "albedo", "sigma_s", "sigma_a", "preset", "color",
                "mean_free_path", "scale", "g", "phase"});
    const char* forms[][2] = {{"sigma_t", "albedo"},
                              {"sigma_s", "sigma_a"},
                              {"preset", ""},
                              {"color", "mean_free_path"}};
    const char* all_forms =
        "sigma_t + albedo, sigma_s + sigma_a, preset, or color + mean_free_path";
    std::string given;
    int form = -1;
    for (int i = 0; i < 4; ++i) {
        for (const char* key : forms[i]) {
            if (!*key || !j.contains(key)) continue;
            if (form >= 0 && form != i)
                f.error("give exactly one of ", all_forms, " (got ", given, " and ", key,
                        ")");
            if (form < 0) given = key;
            form = i;
        }
    }
    if (form < 0) f.error("missing a medium: give ", all_forms);
    for (const char* key : forms[form])
        if (*key && !j.contains(key))
            f.error(given, " needs ", key, " (", forms[form][0], " + ", forms[form][1],
                    ")");
    const double scale =
        j.contains("scale")
            ? number_in(j["scale"], f.at("scale"), 1e-9, 1e9,
                        "a number in [1e-9, 1e9] (coefficients per scene unit "
                        "= the stated ones x scale)")
            : 1.0;
    Medium m;
    m.phase = parse_phase(j, f);
    Vec3 sigma_s, sigma_a;
    if (form == 0) {
        m.sigma_t = rgb_in(j["sigma_t"], f.at("sigma_t"), 0.0, 1e7,
                           "per-channel extinction in [0, 1e7] per scene unit");
        m.albedo =
            rgb_in(j["albedo"], f.at("albedo"), 0.0, 1.0, "each channel in [0, 1]");
        sigma_s = m.sigma_t * m.albedo;
        sigma_a = m.sigma_t - sigma_s;
    } else if (form == 1) {
        sigma_s = rgb_in(j["sigma_s"], f.at("sigma_s"), 0.0, 1e7,
                         "per-channel scattering in [0, 1e7] per scene unit");
        sigma_a = rgb_in(j["sigma_a"], f.at("sigma_a"), 0.0, 1e7,
                         "per-channel absorption in [0, 1e7] per scene unit");
    } else if (form == 3) {
        const Vec3 color =
            rgb_in(j["color"], f.at("color"), 0.0, 1.0, "each channel in [0, 1]");
        const Vec3 mfp = rgb_in(j["mean_free_path"], f.at("mean_free_path"), 1e-7, 1e7,
                                "per-channel distance in [1e-7, 1e7] scene units");
        SSS_CHECK(std::string(m.phase.kind().name) == "hg");
        const ReducedCoefficients r = invert_multiple_scattering_albedo(color, mfp);
        sigma_s = r.sigma_s_prime / (1.f - m.phase.x);
        sigma_a = r.sigma_a;
    } else {
        const json& name = j["preset"];
        const MediumPreset* preset = nullptr;
        std::string names;
        for (const MediumPreset& p : medium_presets()) {
            if (name.is_string() && name.get<std::string>() == p.name) preset = &p;
            names += std::string(names.empty() ? "" : ", ") + p.name;
        }
        if (!preset)
            f.at("preset").error("value ", show(name),
                                 " is not a preset (allowed: ", names,
                                 "; `sssphere presets` lists them with their values)");
        // Reduced scattering back to scattering for this medium's mean cosine g
        // (Henyey-Greenstein's parameter; the only phase function so far).
        SSS_CHECK(std::string(m.phase.kind().name) == "hg");
        const float g = m.phase.x;
        sigma_s = preset->sigma_s_prime / (1.f - g);
        sigma_a = preset->sigma_a;
    }
    if (form != 0 || scale != 1.0) {
        sigma_s = sigma_s * float(scale);
        sigma_a = sigma_a * float(scale);
        m.sigma_t = sigma_s + sigma_a;
        for (int c = 0; c < 3; ++c) {
            if (!(m.sigma_t[c] <= 1e7f))
                f.error("extinction ", m.sigma_t[c], " per scene unit in channel ", c,
                        " is above 1e7 (lower scale)");
            m.albedo[c] =
                m.sigma_t[c] > 0.f ? std::min(1.f, sigma_s[c] / m.sigma_t[c]) : 0.f;
        }
    }
    return m;
}

// A shape as parsed: its mesh, and the mesh's positions in the scene file's coordinates
// (double), which parse_scene moves into the render frame.
struct ParsedShape {
    Shape shape;
    std::vector<Vec3d> positions;
    std::string file;  // the mesh file, if any
    std::vector<std::string> warnings;
};

Surface parse_surface(const json& j, const Field& f) {
    const SurfaceKind& kind = kind_named(surface_kinds(), j, f);
    std::vector<const char*> keys{"type"};
    keys.insert(keys.end(), kind.keys.begin(), kind.keys.end());
    check_keys(j, f, keys);
    Surface s;
    static_cast<SurfaceData&>(s) = kind.parse(j, f);
    s.type = kind.id;
    return s;
}

// An inline mesh: "vertices" [[x, y, z], ...] and "faces" [[i, j, k, ...], ...] (polygons
// of vertex indices), as the Python API passes numpy arrays.
TriangleMesh parse_inline_mesh(const json& j, const Field& f, MeshKind kind) {
    constexpr size_t kMaxElements = size_t(1) << 24;
    const json& vj = j["vertices"];
    const json& fj = require(j, "faces", f);
    const Field fv = f.at("vertices"), ff = f.at("faces");
    if (!vj.is_array() || vj.empty() || vj.size() > kMaxElements)
        fv.error("expected an array of 1 to 2^24 [x, y, z] points, got ", show(vj));
    if (!fj.is_array() || fj.empty() || fj.size() > kMaxElements)
        ff.error("expected an array of 1 to 2^24 faces (arrays of vertex indices), got ",
                 show(fj));
    std::vector<Vec3d> positions;
    positions.reserve(vj.size());
    for (size_t i = 0; i < vj.size(); ++i) {
        const Vec3d p = point3(vj[i], fv.at(i));
        if (!is_finite(p.to_float())) fv.at(i).error("is out of single-precision range");
        positions.push_back(p);
    }
    std::vector<std::vector<uint32_t>> polygons(fj.size());
    for (size_t i = 0; i < fj.size(); ++i) {
        const json& face = fj[i];
        if (!face.is_array() || face.size() < 3 || face.size() > 64)
            ff.at(i).error("expected 3 to 64 vertex indices, got ", show(face));
        for (size_t k = 0; k < face.size(); ++k)
            polygons[i].push_back(uint32_t(integer_in(face[k], ff.at(i).at(k), 0,
                                                      int64_t(positions.size()) - 1,
                                                      "an index into 'vertices'")));
    }
    try {
        const Vec3d origin = center_of_bounds(positions, polygons);
        return kind == MeshKind::Open
                   ? make_open_mesh(positions, std::move(polygons), "inline mesh", origin)
                   : make_closed_mesh(positions, std::move(polygons), "inline mesh",
                                      origin);
    } catch (const Error& e) {
        f.error(e.what());
    }
}

ParsedShape parse_shape(const json& j, const Field& f, const std::string& base_dir,
                        MeshCache* meshes) {
    check_keys(j, f,
               {"name", "mesh", "sphere", "vertices", "faces", "normalize", "transform",
                "medium", "boundary", "surface"});
    Shape s;
    // A medium or an opaque surface, decided first: a surface's mesh may be open.
    if (j.contains("medium") == j.contains("surface"))
        f.error("give exactly one of 'medium' (a translucent shape) or 'surface' (an ",
                "opaque one)");
    if (j.contains("surface")) {
        if (j.contains("boundary"))
            f.at("boundary")
                .error("an opaque surface has no boundary (allowed: ",
                       "'boundary' with a 'medium' only)");
        s.surface = parse_surface(j["surface"], f.at("surface"));
    }
    if (j.contains("name")) {
        if (!j["name"].is_string())
            f.at("name").error("expected a string, got ", show(j["name"]));
        s.name = j["name"].get<std::string>();
    } else {
        s.name = f.path;
    }
    const bool has_mesh = j.contains("mesh"), has_sphere = j.contains("sphere"),
               has_inline = j.contains("vertices");
    if (int(has_mesh) + int(has_sphere) + int(has_inline) != 1)
        f.error(
            "give exactly one of 'mesh' (a file), 'sphere' or 'vertices' with 'faces'");
    if (j.contains("faces") && !has_inline)
        f.at("faces").error("'faces' needs 'vertices' beside it");
    const MeshKind mesh_kind = s.is_surface() ? MeshKind::Open : MeshKind::Closed;
    // The sphere's centre joins the transform (in double): the mesh is built about 0.
    Vec3d center;
    std::string file;
    if (has_mesh) {
        const json& m = j["mesh"];
        if (!m.is_string())
            f.at("mesh").error("expected a file path string, got ", show(m));
        std::filesystem::path p(m.get<std::string>());
        if (p.is_relative()) p = std::filesystem::path(base_dir) / p;
        file = p.string();
        try {
            s.mesh = meshes ? meshes->load(p.string(), mesh_kind)
                            : load_mesh(p.string(), mesh_kind);
        } catch (const Error& e) {
            f.at("mesh").error(e.what());
        }
    } else if (has_inline) {
        s.mesh = parse_inline_mesh(j, f, mesh_kind);
    } else {
        const json& sp = j["sphere"];
        Field fs = f.at("sphere");
        check_keys(sp, fs, {"center", "radius", "subdivisions"});
        center = point3(require(sp, "center", fs), fs.at("center"));
        float radius = float(number_in(require(sp, "radius", fs), fs.at("radius"), 1e-30,
                                       1e30, "a radius in [1e-30, 1e30]"));
        int sub = sp.contains("subdivisions")
                      ? int(integer_in(sp["subdivisions"], fs.at("subdivisions"), 0, 7,
                                       "0 to 7"))
                      : 5;
        s.mesh = make_icosphere(Vec3(0.f), radius, sub);
    }
    if (j.contains("normalize")) {
        if (!j["normalize"].is_boolean())
            f.at("normalize").error("expected true or false, got ", show(j["normalize"]));
        if (j["normalize"].get<bool>()) {
            normalize_mesh(
                s.mesh);  // centred at 0: where the sphere was no longer matters
            center = Vec3d();
        }
    }
    Transform t;
    if (j.contains("transform")) {
        const json& tj = j["transform"];
        Field ft = f.at("transform");
        check_keys(tj, ft, {"scale", "rotate_deg", "translate"});
        if (tj.contains("scale")) {
            t.scale = tj["scale"].is_number()
                          ? Vec3d(1, 1, 1) * number(tj["scale"], ft.at("scale"))
                          : point3(tj["scale"], ft.at("scale"));
            if (!(std::abs(t.scale.x * t.scale.y * t.scale.z) > 0.0))
                ft.at("scale").error("value ", show(tj["scale"]),
                                     " is not allowed (allowed: non-zero scale factors)");
        }
        if (tj.contains("rotate_deg"))
            t.rotate_deg = point3(tj["rotate_deg"], ft.at("rotate_deg"));
        if (tj.contains("translate"))
            t.translate = point3(tj["translate"], ft.at("translate"));
    }
    // The sphere's centre comes before the transform: translate + R (scale (p + centre))
    Transform about_center = t;
    about_center.translate = t.translate + t.apply(center) - t.apply(Vec3d());
    std::vector<Vec3d> positions = transform_mesh(s.mesh, about_center);
    for (const Vec3d& p : positions)
        if (!is_finite(p.to_float()))
            f.at("transform").error("moves the mesh out of single-precision range");
    if (s.is_surface()) return {std::move(s), std::move(positions), file, {}};
    s.medium = parse_medium(j["medium"], f.at("medium"));
    std::vector<std::string> warnings;
    if (j.contains("boundary")) {
        s.boundary = parse_boundary(j["boundary"], f.at("boundary"));
        // parse_boundary took a dielectric of ior near 1 for index-matched: say so, as a
        // user who set 1.005 for a faint interface would not expect none.
        const json& bj = j["boundary"];
        if (bj["type"] == "dielectric" && bj.contains("ior") && bj["ior"] != 1 &&
            std::string(s.boundary.kind().name) != "dielectric")
            warnings.push_back(f.source + ": " + f.at("boundary").at("ior").path + ": " +
                               show(bj["ior"]) +
                               " is within 0.01 of 1: rendered as index-matched, with no "
                               "interface (docs/scene-format.md)");
    }
    return {std::move(s), std::move(positions), file, std::move(warnings)};
}

Light parse_light(const json& j, const Field& f, const LightContext& ctx) {
    const LightType* kind = &kind_named(light_types(), j, f);
    std::vector<const char*> keys{"type"};
    keys.insert(keys.end(), kind->keys.begin(), kind->keys.end());
    keys.insert(keys.end(), kind->optional.begin(), kind->optional.end());
    check_keys(j, f, keys);
    Light l;
    static_cast<LightData&>(l) = kind->parse(j, f, ctx);
    l.type = kind->id;
    return l;
}

RenderSettings parse_render(const json& j, const Field& f, const std::string& base_dir) {
    check_keys(j, f,
               {"integrator", "spp", "seed", "max_bounces", "grid_resolution",
                "sphere_threshold", "models", "time_limit"});
    RenderSettings r;
    if (j.contains("integrator"))
        r.integrator = string_in(j["integrator"], f.at("integrator"), {"pt", "st"});
    if (j.contains("spp"))
        r.spp = int(integer_in(j["spp"], f.at("spp"), 1, 1 << 24, "1 to 16,777,216"));
    if (j.contains("seed"))
        r.seed = uint64_t(integer_in(j["seed"], f.at("seed"), 0, INT64_MAX,
                                     "an integer in [0, 2^63 - 1]"));
    if (j.contains("max_bounces"))
        r.max_bounces = int(integer_in(j["max_bounces"], f.at("max_bounces"), -1,
                                       INT32_MAX, "-1 (no limit) to 2147483647"));
    if (j.contains("grid_resolution"))
        r.grid_resolution = int(integer_in(j["grid_resolution"], f.at("grid_resolution"),
                                           2, 512, "2 to 512"));
    if (j.contains("time_limit"))
        r.time_limit = number_in(j["time_limit"], f.at("time_limit"), 0.0, 1e9,
                                 "0 (no limit) to 1e9 seconds");
    if (j.contains("sphere_threshold"))
        // JSON has no inf: a number past float's range (1e39) says "no sphere steps",
        // as sphere_threshold=inf does for the option.
        r.sphere_threshold =
            float(number_in(j["sphere_threshold"], f.at("sphere_threshold"), 0.0,
                            std::numeric_limits<double>::max(), "a number >= 0"));
    if (j.contains("models")) {
        const json& m = j["models"];
        if (!m.is_string() || m.get<std::string>().empty())
            f.at("models").error("expected a directory path string, got ", show(m));
        std::filesystem::path p(m.get<std::string>());
        if (p.is_relative()) p = std::filesystem::path(base_dir) / p;
        r.models = p.string();
    }
    return r;
}

// Warnings (not errors) where a scene goes past what float precision renders within 1 %
// (docs/robustness.md, "Limits"): a medium whose mean thickness (mean chord 4 V / A,
// twice the thickness of a slab) is below kMinThickness of twice its largest coordinate
// in the render frame, a dense one whose crossings skip more than kMaxCrossingDepth mean
// free paths, or a camera or light farther than kMaxDistance extents from the shapes.
constexpr double kMinThickness = 1.5e-4, kMaxDistance = 1e5;
// A boundary crossing's skip relative to the coordinates, and the optical depth past
// which a medium is warned of.
constexpr double kCrossingSkip = 4.2e-7, kMaxCrossingDepth = 0.1;
// The shapes' extent in scene units: past these, Embree's float ray-triangle test
// overflows (its numerator grows as the cube of the coordinates) or loses its precision
// to subnormals. Image means agreed to 3e-5 from 1e-10 to 1e12 (docs/robustness.md).
constexpr double kMinExtent = 1e-8, kMaxExtent = 1e10;

void warn_past_limits(SceneDesc& d, double extent) {
    auto fmt = [](double v) {
        std::ostringstream os;
        os << v;
        return os.str();
    };
    // A crossing into a medium skips about kCrossingSkip of its coordinates' magnitude
    // (the hit point's rounding bound, gamma_7 |p|: shared/ray_offset.h): r, its largest
    // coordinate in the render frame (half the media's extent for one centred medium). A
    // thin medium feels it against its thickness; a dense one far from the frame's centre
    // in optical depth. Measured (an index-matched sphere, sigma_t 1000, albedo 0.995,
    // moved off centre): 0.35 mean free paths darkened it by 1.4 %, 1.1 by 4.4 %; 0.035
    // by 0.2 % (within the noise).
    for (size_t i = 0; i < d.shapes.size(); ++i) {
        if (d.shapes[i].is_surface()) continue;  // no inside to be thin or dense
        const TriangleMesh& m = d.shapes[i].mesh;
        double r = 0.0;
        for (const Vec3& p : m.positions) r = std::max(r, double(max_component(abs(p))));
        const double thickness = 4.0 * m.volume() / m.area();  // mean chord length
        if (thickness < kMinThickness * 2.0 * r)
            d.warnings.push_back(
                d.source + ": shapes[" + std::to_string(i) + "] ('" + d.shapes[i].name +
                "'): mean thickness 4 V / A = " + fmt(thickness) + " is below " +
                fmt(kMinThickness) + " of 2 r = " + fmt(2.0 * r) +
                ", r its largest coordinate from the centre of the media's bounds: "
                "boundary crossings may bias it by more than 1 % (docs/robustness.md)");
        const double sigma = max_component(d.shapes[i].medium.sigma_t);
        const double skip = kCrossingSkip * r, depth = sigma * skip;
        if (depth > kMaxCrossingDepth)
            d.warnings.push_back(
                d.source + ": shapes[" + std::to_string(i) + "] ('" + d.shapes[i].name +
                "'): lies up to " + fmt(r) +
                " from the centre of the media's bounds, where a boundary crossing skips "
                "about " +
                fmt(skip) + ", " + fmt(depth) +
                " mean free paths of its medium (sigma_t " + fmt(sigma) + ", more than " +
                fmt(kMaxCrossingDepth) +
                "): float precision may bias it by 0.4 % or more (docs/robustness.md); "
                "dense media far apart render best as scenes of their own");
    }
    auto check_distance = [&](Vec3 p, const std::string& what) {
        // from the media's centre, the render frame's origin (in double: no overflow)
        const double r = length(Vec3d(p));
        if (r > kMaxDistance * extent)
            d.warnings.push_back(
                d.source + ": " + what + " lies " + fmt(r / extent) +
                " times the shapes' extent from them (more than " + fmt(kMaxDistance) +
                "): float precision may distort the shapes by more than 1 % "
                "(docs/robustness.md)");
    };
    check_distance(d.camera.origin, "camera.origin");
    for (size_t i = 0; i < d.lights.size(); ++i) {
        const Light& l = d.lights[i];
        const std::string what = "lights[" + std::to_string(i) + "]";
        if (const char* key = l.kind().position_key)
            check_distance(l.a, what + "." + key);
    }
}

}  // namespace

TriangleMesh MeshCache::load(const std::string& path, MeshKind kind) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    const auto time = std::filesystem::last_write_time(path, ec);
    if (ec) return load_mesh(path, kind);  // says what is wrong with the file
    const std::string key = path + '\n' + std::to_string(int(kind)) + '\n' +
                            std::to_string(size) + '\n' +
                            std::to_string(time.time_since_epoch().count());
    auto it = meshes_.find(key);
    if (it == meshes_.end()) it = meshes_.emplace(key, load_mesh(path, kind)).first;
    return it->second;
}

SceneDesc parse_scene(const std::string& json_text, const std::string& base_dir,
                      const std::string& source, MeshCache* meshes) {
    json root = parse_json(json_text, source);
    SceneDesc d;
    d.source = source;
    d.base_dir = base_dir;
    Field f{d.source, ""};
    if (!root.is_object())
        fail(source, ": the scene must be a JSON object, got ", show(root));
    check_keys(root, Field{d.source, "(top level)"},
               {"camera", "shapes", "lights", "render"});
    const json& camera = require(root, "camera", Field{d.source, "(top level)"});
    const json& shapes = require(root, "shapes", Field{d.source, "(top level)"});
    if (!shapes.is_array() || shapes.empty())
        f.at("shapes").error("expected a non-empty array of shapes, got ", show(shapes));
    std::vector<ParsedShape> parsed;
    for (size_t i = 0; i < shapes.size(); ++i)
        parsed.push_back(parse_shape(shapes[i], f.at("shapes").at(i), base_dir, meshes));
    // The render frame: the file's coordinates less the centre of the media's bounds (of
    // the shapes' if there is no medium), in double, then rounded to float. Moving the
    // whole scene moves this centre alike, so the float numbers the renderer sees, and
    // its image, stay the same (docs/robustness.md). The media's: a boundary crossing
    // skips a rounding-level fraction of the coordinates, which in a dense medium is a
    // fraction of a mean free path; centred on all shapes, a floor reaching far to one
    // side (or a speck far away) put the medium off centre and darkened it (4 % at 3000
    // units, sigma_t 1000), and let a lamp under the floor light it.
    Vec3d lo(INFINITY, INFINITY, INFINITY), hi(-INFINITY, -INFINITY, -INFINITY);
    Vec3d media_lo = lo, media_hi = hi;
    for (const ParsedShape& ps : parsed)
        for (const Vec3d& p : ps.positions)
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min(lo[a], p[a]);
                hi[a] = std::max(hi[a], p[a]);
                if (ps.shape.is_surface()) continue;
                media_lo[a] = std::min(media_lo[a], p[a]);
                media_hi[a] = std::max(media_hi[a], p[a]);
            }
    const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
    if (!(extent >= kMinExtent && extent <= kMaxExtent))
        f.at("shapes").error(
            "their extent ", extent,
            " (the largest side of their bounding box) is outside [1e-8, 1e10] scene "
            "units, where single-precision ray-triangle tests hold (docs/robustness.md); "
            "give the scene in other units");
    const bool any_medium = media_lo.x <= media_hi.x;
    d.origin = any_medium ? (media_lo + media_hi) * 0.5 : (lo + hi) * 0.5;
    for (size_t k = 0; k < parsed.size(); ++k) {
        ParsedShape& ps = parsed[k];
        for (size_t i = 0; i < ps.positions.size(); ++i)
            ps.shape.mesh.positions[i] = (ps.positions[i] - d.origin).to_float();
        ps.shape.mesh.origin = Vec3d();
        // The file's mesh enclosed a volume (make_closed_mesh); its transform (a scale of
        // 1e-50 on one axis) or the frame's float rounding (a plate 1e-8 thick at 0.5)
        // may leave none, and a medium with no inside hung the grid's build.
        if (!ps.shape.is_surface())
            check_encloses_volume(ps.shape.mesh,
                                  source + ": shapes[" + std::to_string(k) + "] ('" +
                                      ps.shape.name +
                                      "'), after its transform, in the render frame's "
                                      "single precision");
        d.shapes.push_back(std::move(ps.shape));
        if (!ps.file.empty()) d.inputs.push_back(ps.file);
        d.warnings.insert(d.warnings.end(), ps.warnings.begin(), ps.warnings.end());
    }
    d.camera = parse_camera(camera, f.at("camera"), d.origin);
    if (root.contains("lights")) {
        const json& lights = root["lights"];
        if (!lights.is_array())
            f.at("lights").error("expected an array of lights, got ", show(lights));
        int environments = 0;
        LightContext ctx;
        ctx.frame = d.origin;
        ctx.base_dir = base_dir;
        ctx.floats = &d.light_floats;
        ctx.inputs = &d.inputs;
        for (size_t i = 0; i < lights.size(); ++i) {
            d.lights.push_back(parse_light(lights[i], f.at("lights").at(i), ctx));
            if (d.lights.back().kind().environment && ++environments > 1)
                f.at("lights").at(i).error("a scene has at most one environment light");
        }
    }
    if (root.contains("render"))
        d.render = parse_render(root["render"], f.at("render"), base_dir);
    warn_past_limits(d, extent);
    return d;
}

Light parse_light(const std::string& json_text, const std::string& source, Vec3d frame,
                  const std::string& base_dir, std::vector<float>* floats) {
    std::vector<float> scratch;
    LightContext ctx;
    ctx.frame = frame;
    ctx.base_dir = base_dir;
    ctx.floats = floats ? floats : &scratch;
    return parse_light(parse_json(json_text, source), Field{source, ""}, ctx);
}

Phase parse_phase(const std::string& medium_json, const std::string& source) {
    return parse_phase(parse_json(medium_json, source), Field{source, ""});
}

Medium parse_medium(const std::string& medium_json, const std::string& source) {
    const json j = parse_json(medium_json, source);
    if (!j.is_object()) fail(source, ": a medium must be a JSON object, got ", show(j));
    return parse_medium(j, Field{source, ""});
}

Boundary parse_boundary(const std::string& json_text, const std::string& source) {
    return parse_boundary(parse_json(json_text, source), Field{source, ""});
}

Surface parse_surface(const std::string& json_text, const std::string& source) {
    return parse_surface(parse_json(json_text, source), Field{source, ""});
}

namespace {

// One --set PATH=VALUE on a scene's JSON: PATH as the parser's messages name fields
// (shapes[0].medium.sigma_t); every part but the last must exist, the last may be new.
// VALUE is JSON, or else a string.
// Returns the field's path as set (trimmed).
std::string set_scene_field(json& root, const std::string& assignment) {
    const size_t eq = assignment.find('=');
    if (eq == std::string::npos)
        fail("--set ", assignment,
             ": expected PATH=VALUE, e.g. shapes[0].medium.sigma_t=1000");
    auto trim = [](std::string t) {
        const size_t a = t.find_first_not_of(" \t"), b = t.find_last_not_of(" \t");
        return a == std::string::npos ? std::string() : t.substr(a, b - a + 1);
    };
    const std::string path = trim(assignment.substr(0, eq));
    const std::string text = trim(assignment.substr(eq + 1));
    if (path.empty())
        fail("--set ", assignment,
             ": no PATH before '='; expected PATH=VALUE, e.g. "
             "shapes[0].medium.sigma_t=1000");
    // JSON (checked as a scene file is: a key given twice is refused), else a string. A
    // number JSON cannot hold (1e400) is an error, not the string "1e400".
    static const std::regex json_number(
        R"(-?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][-+]?[0-9]+)?)");
    const json value = json::accept(text) || std::regex_match(text, json_number)
                           ? parse_json(text, "--set " + path)
                           : json(text);
    // Tokens: names, and [index] after a name.
    std::vector<std::variant<std::string, size_t>> tokens;
    size_t i = 0;
    while (i < path.size()) {
        size_t j = i;
        while (j < path.size() &&
               (std::isalnum((unsigned char)path[j]) || path[j] == '_'))
            ++j;
        if (j == i)
            fail("--set ", path, ": expected a field name at '", path.substr(i),
                 "' (e.g. shapes[0].medium.sigma_t)");
        tokens.emplace_back(path.substr(i, j - i));
        while (j < path.size() && path[j] == '[') {
            const size_t close = path.find(']', j);
            const std::string digits =
                close == std::string::npos ? "" : path.substr(j + 1, close - j - 1);
            if (digits.empty() ||
                digits.find_first_not_of("0123456789") != std::string::npos ||
                digits.size() > 9)
                fail("--set ", path, ": expected [index] with a number at '",
                     path.substr(j), "'");
            tokens.emplace_back(size_t(std::stoul(digits)));
            j = close + 1;
        }
        if (j < path.size() && path[j] != '.')
            fail("--set ", path, ": unexpected '", path.substr(j), "'");
        i = j + 1;
        if (j + 1 == path.size()) fail("--set ", path, ": ends with '.'");
    }
    json* node = &root;
    std::string where;
    for (size_t k = 0; k < tokens.size(); ++k) {
        const bool last = k + 1 == tokens.size();
        if (const size_t* index = std::get_if<size_t>(&tokens[k])) {
            if (!node->is_array()) fail("--set ", path, ": ", where, " is not a list");
            if (*index >= node->size())
                fail("--set ", path, ": ", where, " has ", node->size(), " entries, no [",
                     *index, "]");
            node = &(*node)[*index];
            where += "[" + std::to_string(*index) + "]";
        } else {
            const std::string& key = std::get<std::string>(tokens[k]);
            if (!node->is_object())
                fail("--set ", path, ": ", where.empty() ? "the scene" : where,
                     " is not an object");
            const std::string name = where.empty() ? key : where + "." + key;
            // An object on the way that is not there is made (an optional block: the
            // scene's `render`, a medium's `transform`); the parser then checks its keys.
            // A list is not: its entries' positions would be guesses.
            if (!last && !node->contains(key)) {
                if (!std::holds_alternative<std::string>(tokens[k + 1]))
                    fail("--set ", path, ": ", name, " is not in the scene");
                (*node)[key] = json::object();
            }
            node = &(*node)[key];
            where = name;
        }
        if (last) *node = value;
    }
    return path;
}

}  // namespace

std::string edit_scene_json(const std::string& json_text, const std::string& source,
                            const std::vector<std::string>& assignments, int width,
                            int height) {
    json root = parse_json(json_text, source);
    if (!root.is_object()) return json_text;  // parse_scene says what is wrong
    for (const std::string& a : assignments) {
        const std::string path = set_scene_field(root, a);
        // --width and --height would silently replace what this set (unchecked).
        for (const char* field : {"camera", "camera.width", "camera.height"})
            if (path == field && (width > 0 || height > 0))
                fail("--set ", path,
                     " and --width/--height both give the image size: "
                     "give one of them");
    }
    if (width > 0 || height > 0) {
        json& camera = root["camera"];
        if (!camera.is_object()) return root.dump();
        // One of them alone keeps the camera's aspect ratio.
        const json w = camera.value("width", json()), h = camera.value("height", json());
        if (width > 0 && height <= 0 && w.is_number_integer() && h.is_number_integer() &&
            w.get<int64_t>() > 0)
            height = std::max<int64_t>(
                1, std::llround(double(h.get<int64_t>()) * width / w.get<int64_t>()));
        if (height > 0 && width <= 0 && w.is_number_integer() && h.is_number_integer() &&
            h.get<int64_t>() > 0)
            width = std::max<int64_t>(
                1, std::llround(double(w.get<int64_t>()) * height / h.get<int64_t>()));
        if (width > 0) camera["width"] = width;
        if (height > 0) camera["height"] = height;
    }
    return root.dump();
}

SceneDesc load_scene_file(const std::string& path,
                          const std::vector<std::string>& assignments, int width,
                          int height) {
    namespace fs = std::filesystem;
    std::string text = read_input_file(path, "scene file");
    std::string base = fs::path(path).parent_path().string();
    if (!assignments.empty() || width > 0 || height > 0)
        text = edit_scene_json(text, path, assignments, width, height);
    return parse_scene(text, base.empty() ? "." : base, path);
}

Scene::Scene(SceneDesc desc, int threads, const StopFn& stop) : desc_(std::move(desc)) {
    build(threads, nullptr, stop);
}

Scene::Scene(SceneDesc desc, int threads, const Scene& previous, const StopFn& stop)
    : desc_(std::move(desc)) {
    build(threads, &previous, stop);
}

namespace {

bool same_mesh(const TriangleMesh& a, const TriangleMesh& b) {
    return a.positions == b.positions && a.triangles == b.triangles;
}

}  // namespace

// A path inside a medium takes any other surface it meets for its own boundary, and
// leaves to vacuum there: media that overlap, touch or nest, and area lights inside or
// across a medium, would render wrong without a word. Exact (CGAL), pairs whose boxes
// meet only; on an edit (`previous`), only pairs with a shape or quad that changed.
// Media nearly touching are refused too: a ray leaving one starts a few float steps of
// the coordinates past its surface, and could start past the other's (a sweep measured
// 93 % of the light lost across a gap of 1.5e-7 of the scene). Where opaque surfaces meet
// media is found here too (contacts_, for the tracers and the grids).
void Scene::check_media_apart(const std::vector<TriangleMesh>& quads,
                              const Scene* previous) {
    auto name = [&](size_t i) {
        return "shapes[" + std::to_string(i) + "] ('" + desc_.shapes[i].name + "')";
    };
    std::vector<bool> changed(desc_.shapes.size(), true),
        quad_changed(quads.size(), true);
    if (previous) {
        for (size_t i = 0; i < desc_.shapes.size() && i < previous->desc_.shapes.size();
             ++i)
            changed[i] =
                desc_.shapes[i].is_surface() != previous->desc_.shapes[i].is_surface() ||
                !same_mesh(desc_.shapes[i].mesh, previous->desc_.shapes[i].mesh);
        for (size_t k = 0; k < quads.size() && k < previous->area_lights_.size(); ++k)
            quad_changed[k] = !same_mesh(
                quads[k], previous->desc_.lights[previous->area_lights_[k]].quad_mesh());
    }
    for (size_t i = 0; i < desc_.shapes.size(); ++i) {
        if (desc_.shapes[i].is_surface()) continue;
        for (size_t j = i + 1; j < desc_.shapes.size(); ++j) {
            if (desc_.shapes[j].is_surface() || !(changed[i] || changed[j])) continue;
            const TriangleMesh &a = desc_.shapes[i].mesh, &b = desc_.shapes[j].mesh;
            if (meshes_meet(a, b, true))
                fail(desc_.source, ": ", name(i), " and ", name(j),
                     ": their media overlap, touch or lie one inside the other (allowed: "
                     "media apart, by 1e-5 of the scene or more; nested media are not "
                     "supported; two pieces of one medium can be one mesh)");
            NearContact near = near_contact(a, b);
            if (near.gap < near.needed)
                fail(desc_.source, ": ", name(i), " and ", name(j), ": their media are ",
                     near.gap, " apart, too close for rays that leave a surface at an ",
                     "offset the size of the coordinates' rounding (allowed: a gap of ",
                     near.needed, " or more there; 1e-5 of the scene is always enough; ",
                     "two pieces of one medium can be one mesh)");
        }
        for (size_t j = 0; j < desc_.shapes.size(); ++j) {
            if (!desc_.shapes[j].is_surface()) continue;
            if (previous && !changed[i] && !changed[j]) {
                for (const auto& c : previous->contacts_)
                    if (std::get<0>(c) == int(i) && std::get<1>(c) == int(j))
                        contacts_.push_back(c);
                continue;
            }
            const SurfaceContact contact =
                surface_contact(desc_.shapes[i].mesh, desc_.shapes[j].mesh);
            if (contact.meets()) contacts_.emplace_back(int(i), int(j), contact);
        }
        for (size_t k = 0; k < quads.size(); ++k)
            if ((changed[i] || quad_changed[k]) &&
                meshes_meet(desc_.shapes[i].mesh, quads[k], false))
                fail(desc_.source, ": lights[", area_lights_[k],
                     "]: the area light meets ", name(i),
                     ", inside it or across its surface (allowed: area lights "
                     "outside every medium)");
    }
}

void Scene::build(int threads, const Scene* previous, const StopFn& stop) {
    std::vector<TriangleMesh> quads;
    for (size_t i = 0; i < desc_.lights.size(); ++i) {
        const Light& l = desc_.lights[i];
        if (l.kind().environment) environment_ = int(i);
        if (!l.kind().quad) continue;
        quads.push_back(l.quad_mesh());
        area_lights_.push_back(int(i));
    }
    for (const Shape& s : desc_.shapes) {
        has_surfaces_ = has_surfaces_ || s.is_surface();
        if (s.is_surface()) continue;
        grey_ = grey_ && s.medium.sigma_t.x == s.medium.sigma_t.y &&
                s.medium.sigma_t.x == s.medium.sigma_t.z;
    }

    // The BVH: kept when every mesh it holds (shapes, then area lights' quads) is the
    // same.
    bool same_meshes = previous && previous->num_shapes() == num_shapes() &&
                       previous->area_lights_.size() == area_lights_.size();
    for (int i = 0; same_meshes && i < num_shapes(); ++i)
        same_meshes = same_mesh(desc_.shapes[i].mesh, previous->desc_.shapes[i].mesh);
    for (size_t k = 0; same_meshes && k < quads.size(); ++k)
        same_meshes = same_mesh(
            quads[k], previous->desc_.lights[previous->area_lights_[k]].quad_mesh());
    bounds_ = Bounds3();
    auto extend = [&](const TriangleMesh& m) {
        const Bounds3 b = m.bounds();
        bounds_.extend(b.lo);
        bounds_.extend(b.hi);
    };
    for (const Shape& s : desc_.shapes) extend(s.mesh);
    for (const TriangleMesh& q : quads) extend(q);
    // Which shapes hold media matters to the media's check, not to the BVH.
    bool same_media = same_meshes;
    for (int i = 0; same_media && i < num_shapes(); ++i)
        same_media =
            desc_.shapes[i].is_surface() == previous->desc_.shapes[i].is_surface();
    if (!same_media)
        check_media_apart(quads, previous);
    else if (previous)
        contacts_ = previous->contacts_;
    if (same_meshes) {
        tracer_ = previous->tracer_;
    } else {
        auto tracer = std::make_shared<RayTracer>();
        for (const Shape& s : desc_.shapes) tracer->add_mesh(s.mesh);
        for (const TriangleMesh& q : quads) tracer->add_mesh(q);
        tracer->commit();
        tracer_ = std::move(tracer);
        rebuilt_.push_back("BVH");
    }

    // The surfaces each medium's grid keeps clear of (a floor through a cube: a flight
    // the grid allowed, or a sphere step, passed it, and 6-14 % of the light got
    // through), and the medium's triangles where the tracers look for a surface too.
    obstacles_.assign(size_t(num_shapes()), TriangleMesh{});
    touching_.assign(size_t(num_shapes()), {});
    for (const auto& [i, j, contact] : contacts_) {
        // Only what could be nearer a grid node than the medium: a large room's walls
        // far from a candle are not copied, nor searched by the grid's build.
        Bounds3 keep = desc_.shapes[size_t(i)].mesh.bounds();
        const float reach = 3.f * length(keep.extent());
        keep.lo = keep.lo - Vec3(reach);
        keep.hi = keep.hi + Vec3(reach);
        append_mesh(obstacles_[size_t(i)], desc_.shapes[size_t(j)].mesh, keep);
        if (contact.touching.empty()) continue;
        std::vector<bool>& touching = touching_[size_t(i)];
        touching.resize(desc_.shapes[size_t(i)].mesh.triangles.size());
        for (uint32_t t : contact.touching) touching[t] = true;
    }

    // The media point lights lie inside (medium_samples_lights, light_scale).
    lit_inside_.assign(size_t(num_shapes()), false);
    light_scale_.assign(desc_.lights.size(), 1.f);
    light_medium_.assign(desc_.lights.size(), -1);
    for (int i = 0; i < num_shapes(); ++i) {
        const Shape& s = desc_.shapes[size_t(i)];
        if (s.is_surface()) continue;
        for (size_t k = 0; k < desc_.lights.size(); ++k) {
            const Light& l = desc_.lights[k];
            if (l.is_delta() && l.kind().position_key && s.mesh.bounds().contains(l.a) &&
                point_inside_mesh(s.mesh, l.a)) {
                lit_inside_[size_t(i)] = true;
                light_medium_[k] = i;
                const float n = boundary_index(s.boundary);
                light_scale_[k] = 1.f / (n * n);
            }
        }
    }

    // A distance grid per medium: kept when its shape's mesh and resolution and the
    // surfaces meeting it are the same.
    for (int i = 0; i < num_shapes(); ++i) {
        const Shape& s = desc_.shapes[i];
        if (s.is_surface()) {  // no medium to step through
            grids_.push_back(std::make_shared<DistanceGrid>());
            grid_resolutions_.push_back(0);
            continue;
        }
        const int res = desc_.render.grid_resolution > 0 ? desc_.render.grid_resolution
                                                         : auto_grid_resolution(s);
        grid_resolutions_.push_back(res);
        const bool had = previous && i < previous->num_shapes() &&
                         !previous->desc_.shapes[i].is_surface();
        const bool same_obstacles =
            had && same_mesh(obstacles_[i], previous->obstacles_[i]);
        if (had && previous->grid_resolutions_[i] == res && same_obstacles &&
            same_mesh(s.mesh, previous->desc_.shapes[i].mesh)) {
            grids_.push_back(previous->grids_[i]);
            continue;
        }
        grids_.push_back(std::make_shared<DistanceGrid>(DistanceGrid::build(
            s.mesh, res, threads, DistanceGrid::kExactResolution, stop, obstacles_[i])));
        if (previous) {
            std::string why = "distance grid of shape '" + s.name + "' (";
            if (!had)
                why += "new";
            else if (!same_mesh(s.mesh, previous->desc_.shapes[i].mesh))
                why += "its mesh changed";
            else if (!same_obstacles)
                why += "the opaque surfaces meeting it changed";
            else
                why += std::to_string(previous->grid_resolutions_[i]) + " -> " +
                       std::to_string(res) + " cells: the resolution follows sigma_t" +
                       " unless render.grid_resolution sets it";
            rebuilt_.push_back(why + ")");
        }
    }
    if (!previous) rebuilt_ = {"everything"};
    // The camera must be outside every medium: the exact test (an AABB tree) only where
    // the bounds and the grid's sign cannot tell, so that a camera edit stays cheap.
    const Vec3 eye = desc_.camera.origin;
    for (size_t i = 0; i < desc_.shapes.size(); ++i) {
        const Shape& s = desc_.shapes[i];
        if (s.is_surface()) continue;
        if (!s.mesh.bounds().contains(eye)) continue;
        const int side = grids_[i]->side(eye);
        const bool inside = side != 0 ? side > 0 : point_inside_mesh(s.mesh, eye);
        if (inside) {
            const Vec3d o = to_scene(desc_.camera.origin);
            fail(desc_.source, ": camera.origin: [", o.x, ", ", o.y, ", ", o.z,
                 "] lies inside shape '", desc_.shapes[i].name,
                 "' (allowed: a camera outside every medium)");
        }
    }
}

float Scene::camera_ray_start() const {
    const Vec3 c = bounds_.center(), e = bounds_.extent(), eye = desc_.camera.origin;
    const double radius =
        0.5 * std::sqrt(double(e.x) * e.x + double(e.y) * e.y + double(e.z) * e.z);
    const double to_eye = std::sqrt(double(eye.x - c.x) * (eye.x - c.x) +
                                    double(eye.y - c.y) * (eye.y - c.y) +
                                    double(eye.z - c.z) * (eye.z - c.z));
    // The margin: a hundredth of the ball's radius, and the float rounding of o + d t.
    const double start = to_eye - 1.01 * radius - 1e-6 * to_eye;
    return start > 0 ? float(start) * (1.f - 1e-6f) : 0.f;
}

bool Scene::other_at(const Vec3& o, const Vec3& d, const Hit& hit, Hit* other) const {
    return tracer_->intersect_skipping(
        o, d, 0.f, tie_reach(o, d, hit.t, hit.p_error, hit.normal), hit.mesh, other);
}

bool Scene::surface_at(const Vec3& o, const Vec3& d, const Hit& face,
                       Hit* surface) const {
    return int(face.mesh) < num_shapes() && touches_surface(int(face.mesh), face.prim) &&
           other_at(o, d, face, surface) && int(surface->mesh) < num_shapes() &&
           desc_.shapes[surface->mesh].is_surface();
}

std::vector<int> Scene::surfaces_meeting(int shape) const {
    std::vector<int> out;
    for (const auto& [i, j, contact] : contacts_)
        if (i == shape) out.push_back(j);
    return out;
}

int Scene::auto_grid_resolution(const Shape& shape) {
    const float side = max_component(shape.mesh.bounds().extent());
    const float across = max_component(shape.medium.sigma_t) * side;
    const float mean_free_paths = across / 64.f;  // in one of 64 cells
    if (mean_free_paths > kFineGridCellMeanFreePaths) return 256;
    if (mean_free_paths > kGridCellMeanFreePaths) return 128;
    for (int cells : {16, 32})
        if (across <= float(cells) * kCoarseGridCellMeanFreePaths) return cells;
    return 64;
}

TriangleMesh Light::quad_mesh() const {
    TriangleMesh quad;
    quad.positions = {a, a + b, a + b + c, a + c};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    return quad;
}

int Scene::area_light_of_mesh(unsigned mesh) const {
    int i = int(mesh) - num_shapes();
    return i >= 0 && i < int(area_lights_.size()) ? area_lights_[i] : -1;
}

}  // namespace sss

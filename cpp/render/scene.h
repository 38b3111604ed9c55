// Scene description (what a scene file says) and the built scene (what the integrators
// read: meshes in Embree, a distance grid per shape). The JSON format is documented in
// docs/scene-format.md; parameter names here are the ones in the file.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/vec.h"
#include "geometry/distance_grid.h"
#include "geometry/mesh.h"
#include "geometry/ray_tracer.h"
#include "render/options.h"

namespace sss {

// Homogeneous medium; sigma_t per scene unit, per RGB channel.
struct Medium {
    Vec3 sigma_t;
    Vec3 albedo;
    float g = 0.f;
};

enum class BoundaryType { IndexMatched, Dielectric };

struct Boundary {
    BoundaryType type = BoundaryType::IndexMatched;
    float ior = 1.5f;  // inside / outside, dielectric only
};

struct Shape {
    std::string name;
    TriangleMesh mesh;  // closed, outward-oriented, in world space
    Medium medium;
    Boundary boundary;
};

struct Camera {
    Vec3 origin, target, up{0, 1, 0};
    float fov = 40.f;  // vertical, degrees
    int width = 256, height = 256;
};

struct Light {
    enum class Type { Point, Directional, Area, Environment };
    Type type = Type::Point;
    Vec3 position, intensity;    // point: W/sr per channel
    Vec3 direction, irradiance;  // directional: unit travel direction, irradiance
    Vec3 corner, edge1, edge2;   // area: quad corner + s*edge1 + t*edge2, emits along
    Vec3 radiance;  //   normalize(edge1 x edge2); environment: constant radiance
    // Point and directional lights: no path can hit them, only light sampling sees them.
    bool is_delta() const { return type == Type::Point || type == Type::Directional; }
};

// Positions in a SceneDesc (meshes, camera, lights) are in the *render frame*: the scene
// file's coordinates less `origin` (the centre of the shapes' bounds, kept in double), so
// that float precision follows the shapes' size, not where they sit (docs/robustness.md).
struct SceneDesc {
    std::string source;  // file name (or "<dict>") used in error messages
    Vec3d origin;        // the render frame's origin in the scene file's coordinates
    Camera camera;
    std::vector<Shape> shapes;
    std::vector<Light> lights;
    RenderSettings render;
    // Where the scene goes past the limits of docs/robustness.md: it renders, but maybe
    // not within 1 %. The command lines print them; Python raises sssphere.SceneWarning.
    std::vector<std::string> warnings;
};

// Parses and validates a scene; mesh paths are relative to `base_dir`. Every error names
// `source`, the field (e.g. shapes[0].medium.albedo), the value and what is allowed.
SceneDesc parse_scene(const std::string& json_text, const std::string& base_dir,
                      const std::string& source);
SceneDesc load_scene_file(const std::string& path);

// The built scene. Immutable after construction and safe to share between threads.
class Scene {
public:
    explicit Scene(SceneDesc desc, int threads = 0);

    const SceneDesc& desc() const { return desc_; }
    const RayTracer& tracer() const { return *tracer_; }
    const DistanceGrid& grid(int shape) const { return grids_[shape]; }
    int num_shapes() const { return int(desc_.shapes.size()); }
    // Embree mesh index of area light i's quad is num_shapes() + i_th area light.
    int area_light_of_mesh(unsigned mesh) const;
    const Light* environment() const { return environment_; }
    // True when every medium has the same sigma_t in all channels (paths then carry RGB).
    bool grey_media() const { return grey_; }
    // Between the scene file's coordinates and the render frame (SceneDesc::origin).
    Vec3 to_render(Vec3d p) const { return (p - desc_.origin).to_float(); }
    Vec3d to_scene(Vec3 p) const { return Vec3d(p) + desc_.origin; }

    // The distance grid's resolution for a shape when the scene sets none: 64 cells along
    // its largest side, or 128 when a 64th of that side is more than
    // kGridCellMeanFreePaths mean free paths of its densest channel. The grid's bound
    // loses up to sqrt(3) cells near the surface, which is where a dense medium's paths
    // spend their events: there the finer grid saves events and boundary rays (measured
    // in bench/README.md), elsewhere it only costs build time and memory.
    static int auto_grid_resolution(const Shape& shape);
    static constexpr float kGridCellMeanFreePaths = 10.f;

private:
    SceneDesc desc_;
    std::unique_ptr<RayTracer> tracer_;
    std::vector<DistanceGrid> grids_;
    std::vector<int> area_lights_;  // light index per extra Embree mesh
    const Light* environment_ = nullptr;
    bool grey_ = true;
};

}  // namespace sss

// Scene description (what a scene file says) and the built scene (what the integrators
// read: meshes in Embree, a distance grid per shape). The JSON format is documented in
// docs/scene-format.md; parameter names here are the ones in the file.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "core/cancel.h"
#include "core/vec.h"
#include "geometry/distance_grid.h"
#include "geometry/mesh.h"
#include "geometry/ray_tracer.h"
#include "render/boundaries/registry.h"
#include "render/lights/registry.h"
#include "render/options.h"
#include "render/phase/registry.h"
#include "render/surfaces/registry.h"

namespace sss {

// A phase function of any type of render/phase/registry.h (PhaseData says what it
// holds); Henyey-Greenstein with g = 0 unless the scene says otherwise.
struct Phase : PhaseData {
    Phase() : PhaseData{} {}
    const PhaseKind& kind() const { return phase_kind(type); }
};

// Homogeneous medium; sigma_t per scene unit, per RGB channel.
struct Medium {
    Vec3 sigma_t;
    Vec3 albedo;
    Phase phase;
};

// A boundary of any type of render/boundaries/registry.h (BoundaryData says what it
// holds); index-matched unless the scene says otherwise.
struct Boundary : BoundaryData {
    Boundary() : BoundaryData{} {}
    const BoundaryKind& kind() const { return boundary_kind(type); }
    bool passes_shadow_rays() const { return boundary_passes_shadow_rays(*this); }
    bool samples_lights() const {
        return boundary_light_sampling(*this) != kSamplesNoLights;
    }
    bool samples_delta_lights_only() const {
        return boundary_light_sampling(*this) == kSamplesDeltaLights;
    }
};

// An opaque surface of any type of render/surfaces/registry.h (SurfaceData says what it
// holds); type -1 (the default) means none: the shape holds a medium.
struct Surface : SurfaceData {
    Surface() : SurfaceData{-1, Vec3(0.f), 0.f} {}
    const SurfaceKind& kind() const { return surface_kind(type); }
};

// A shape is either a medium inside a closed mesh, behind its boundary, or an opaque
// surface (any mesh, open ones too: a floor is two triangles). Surfaces must not reach
// into a medium (docs/scene-format.md).
struct Shape {
    std::string name;
    TriangleMesh mesh;  // in the render frame; closed and outward-oriented for a medium
    Medium medium;      // media only
    Boundary boundary;  // media only
    Surface surface;    // surfaces only
    bool is_surface() const { return surface.type >= 0; }
};

struct Camera {
    Vec3 origin, target, up{0, 1, 0};
    float fov = 40.f;  // vertical, degrees
    int width = 256, height = 256;
};

// A light of any type of render/lights/registry.h (LightData says what it holds).
struct Light : LightData {
    const LightType& kind() const { return light_type(type); }
    // No path can hit it, only light sampling sees it (point and directional lights).
    bool is_delta() const { return kind().delta; }
    // The two triangles of a LightType::quad light, for the ray tracers.
    TriangleMesh quad_mesh() const;
};

// Positions in a SceneDesc (meshes, camera, lights) are in the *render frame*: the scene
// file's coordinates less `origin` (the centre of the media's bounds, else of the
// shapes', kept in double), so that float precision follows the shapes' size, not where
// they sit (docs/robustness.md).
struct SceneDesc {
    std::string source;          // file name (or "<dict>") used in error messages
    std::string base_dir = ".";  // where relative file names (meshes, maps) start
    // The files it reads besides the scene file (meshes, environment maps), as named
    // there (relative ones joined to base_dir): an output must not be one of them.
    std::vector<std::string> inputs;
    Vec3d origin;  // the render frame's origin in the scene file's coordinates
    Camera camera;
    std::vector<Shape> shapes;
    std::vector<Light> lights;
    // The lights' table of floats (environment maps and their sampling tables), which
    // the light types read at offsets in their data (render/lights/light.h).
    std::vector<float> light_floats;
    RenderSettings render;
    // Where the scene goes past the limits of docs/robustness.md: it renders, but maybe
    // not within 1 %. The command lines print them; Python raises sssphere.SceneWarning.
    std::vector<std::string> warnings;
};

// Meshes read from files, kept so that parsing an edited scene again does not read and
// check them again: by the file's path, kind, size and modification time (a file changed
// on disk is read again).
class MeshCache {
public:
    // The mesh of file `path` as load_mesh reads it, from the cache when it has it.
    TriangleMesh load(const std::string& path, MeshKind kind);

private:
    std::map<std::string, TriangleMesh> meshes_;
};

// Parses and validates a scene; mesh paths are relative to `base_dir`. Every error names
// `source`, the field (e.g. shapes[0].medium.albedo), the value and what is allowed.
// With a cache, mesh files are read through it.
SceneDesc parse_scene(const std::string& json_text, const std::string& base_dir,
                      const std::string& source, MeshCache* meshes = nullptr);
// A scene file, with the command lines' changes: `assignments` ("--set PATH=VALUE",
// edit_scene_json) and the image size (> 0: given).
SceneDesc load_scene_file(const std::string& path,
                          const std::vector<std::string>& assignments = {}, int width = 0,
                          int height = 0);
// A scene's JSON text with the command lines' changes: each "PATH=VALUE" sets the field
// PATH (named as the parser's messages name fields, e.g. shapes[0].medium.sigma_t; every
// part but the last must exist) to VALUE (JSON, else a string); width and height (> 0:
// given; one alone keeps the camera's aspect ratio) set the camera's. The parser then
// checks the result as it checks any file.
std::string edit_scene_json(const std::string& json_text, const std::string& source,
                            const std::vector<std::string>& assignments, int width = 0,
                            int height = 0);
// One light from its JSON object, as in a scene file whose render frame has its origin
// at `frame` (relative file names from base_dir). A light that keeps a table appends it
// to *floats (required for such a light: an environment map).
Light parse_light(const std::string& json_text, const std::string& source = "<light>",
                  Vec3d frame = Vec3d(), const std::string& base_dir = ".",
                  std::vector<float>* floats = nullptr);
// A medium's phase function from the medium's JSON object ("phase", or "g" for
// Henyey-Greenstein), as in a scene file.
Phase parse_phase(const std::string& medium_json, const std::string& source = "<medium>");
// A medium from its JSON object, as in a scene file (any way of stating it, resolved to
// sigma_t and albedo per scene unit).
Medium parse_medium(const std::string& medium_json,
                    const std::string& source = "<medium>");
// One boundary from its JSON object, as in a scene file.
Boundary parse_boundary(const std::string& json_text,
                        const std::string& source = "<boundary>");
// One opaque surface from its JSON object, as in a scene file.
Surface parse_surface(const std::string& json_text,
                      const std::string& source = "<surface>");

// The built scene. Immutable after construction and safe to share between threads.
class Scene {
public:
    // `stop` is polled while the distance grids are built (the build's long part): once
    // it returns true the constructor throws Cancelled (core/cancel.h).
    explicit Scene(SceneDesc desc, int threads = 0, const StopFn& stop = {});
    // The scene `desc` (an edit of `previous`'s), built with what of `previous` it can
    // keep: the BVH when no shape's mesh and no area light's quad changed; a shape's
    // distance grid when its mesh and its grid resolution did not. rebuilt() says what
    // was built anew. Both scenes may be used afterwards (the parts are shared).
    Scene(SceneDesc desc, int threads, const Scene& previous, const StopFn& stop = {});

    const SceneDesc& desc() const { return desc_; }
    const RayTracer& tracer() const { return *tracer_; }
    // The distance grid of a medium's shape (a surface's is empty).
    const DistanceGrid& grid(int shape) const { return *grids_[shape]; }
    // The opaque surfaces that meet a medium (through it, inside it or lying on it), as
    // one mesh: its grid's distances and its cut steps' certificates keep clear of them
    // too, so that a flight or a step the grid allows cannot pass one. Empty for most.
    const TriangleMesh& obstacles(int shape) const { return obstacles_[shape]; }
    // How far along a camera ray it can start without passing anything: the camera's
    // distance to the ball around every mesh (shapes and area lights), less a margin; 0
    // inside the ball. From a camera far away, hit distances carry rounding of its
    // coordinates' size, which can order a floor and the face of a cube resting on it
    // wrong by more than the rays' offsets (a sweep saw 534 of 1024 pixels lit through
    // a floor from 300 times the scene's size); from this start, of the scene's.
    float camera_ray_start() const;
    // The opaque surfaces (their shape indices, ascending) that meet a medium's shape:
    // resting on it, through it or inside it (SurfaceContact).
    std::vector<int> surfaces_meeting(int shape) const;
    // Whether triangle `prim` of a medium's shape has an opaque surface within the rays'
    // offsets (SurfaceContact::touching): a ray that hits it may as well have hit that.
    bool touches_surface(int shape, unsigned prim) const {
        const std::vector<bool>& t = touching_[size_t(shape)];
        return !t.empty() && t[prim];
    }
    // Whether any triangle of it does.
    bool touches_surfaces(int shape) const { return !touching_[size_t(shape)].empty(); }
    // Whether light sampling at a scattering event in medium `shape` can reach a light:
    // where its boundary passes shadow rays (index-matched), or where a point light lies
    // inside it, which a shadow ray reaches without meeting the boundary (a candle
    // behind glass). A straight shadow ray never leaves a smooth or rough dielectric
    // (docs/notation.md, "Next-event estimation"), so elsewhere such events sample none.
    bool medium_samples_lights(int shape) const {
        return desc_.shapes[size_t(shape)].boundary.passes_shadow_rays() ||
               lit_inside_[size_t(shape)];
    }
    // The factor on light `i`'s radiance: 1 / n^2 for a point light inside a medium of
    // index n (its boundary's), else 1. The tracers apply no radiance scaling at
    // crossings; a path's scalings telescope to (1 / n at its light end)^2
    // (docs/notation.md, "No η² radiance scaling").
    float light_scale(int i) const { return light_scale_[size_t(i)]; }
    // The medium point light `i` lies inside, on its surface included (CGAL's exact
    // test), or -1.
    int light_medium(int i) const { return light_medium_[size_t(i)]; }
    // Which of a medium's face and a surface lying on it a ray meets first is rounding's
    // choice: a ray leaving the face started past the floor (an outside sweep saw a lit
    // cube through the floor it rests on), and a ray from a camera far away may find the
    // face before a floor a little in front of it. So a ray from o that hits one of them
    // where the other may lie (touches_surface) is traced again, passing through the
    // mesh it hit, to tie_reach past the hit: what it finds there (`other`) it met at the
    // same place, to rounding; false where nothing. The path tracer then meets both;
    // render.glsl's meet_boundary does the same.
    bool other_at(const Vec3& o, const Vec3& d, const Hit& hit, Hit* other) const;
    // The opaque surface lying on a medium's face where the ray hits the face (what the
    // path tracer, and a camera, meet there first); false also where `face` is not a
    // medium's.
    bool surface_at(const Vec3& o, const Vec3& d, const Hit& face, Hit* surface) const;
    // The lights' table of floats, for light_sample and light_eval.
    const float* light_floats() const { return desc_.light_floats.data(); }
    int num_shapes() const { return int(desc_.shapes.size()); }
    // The light whose quad is Embree mesh `mesh` (LightType::quad; the quads follow the
    // shapes, in the order of the lights), or -1.
    int area_light_of_mesh(unsigned mesh) const;
    // The index of the light every escaping ray meets (LightType::environment), or -1.
    int environment() const { return environment_; }
    // Whether some shape is an opaque surface.
    bool has_surfaces() const { return has_surfaces_; }
    // True when every medium has the same sigma_t in all channels (paths then carry RGB).
    bool grey_media() const { return grey_; }
    // Between the scene file's coordinates and the render frame (SceneDesc::origin).
    Vec3 to_render(Vec3d p) const { return (p - desc_.origin).to_float(); }
    Vec3d to_scene(Vec3 p) const { return Vec3d(p) + desc_.origin; }

    // The distance grid's resolution for a shape when the scene sets none: 64 cells along
    // its largest side; 128 when a 64th of that side is more than kGridCellMeanFreePaths
    // mean free paths of its densest channel, 256 when it is more than
    // kFineGridCellMeanFreePaths. The grid's bound loses up to sqrt(3) cells near the
    // surface, which is where a dense medium's paths spend their events: there the finer
    // grid saves events and boundary rays (measured in bench/README.md,
    // "`grid_resolution.py`"); elsewhere it costs memory (67 MB for the bunny at 256
    // cells) and build time (DistanceGrid::build refines only near the surface). A medium
    // at most 16 (32) mean free paths across gets 16 (32) cells, none over
    // kCoarseGridCellMeanFreePaths thick: a finer grid there saved no time (sphere.json,
    // 20 mean free paths across: pt and st within 3 %, the noise, at 16, 32 and 64 cells;
    // bench/small_media.py) and took
    // 1.9 s to build instead of 0.3 s.
    static int auto_grid_resolution(const Shape& shape);
    static constexpr float kCoarseGridCellMeanFreePaths = 1.f;
    static constexpr float kGridCellMeanFreePaths = 10.f;
    static constexpr float kFineGridCellMeanFreePaths = 30.f;

    // The distance grid resolution of each shape (0 for a surface).
    const std::vector<int>& grid_resolutions() const { return grid_resolutions_; }
    // What construction built rather than took from a previous scene, one line each
    // (e.g. "BVH", "distance grid of shape 'bunny' (64 -> 128 cells)").
    const std::vector<std::string>& rebuilt() const { return rebuilt_; }

private:
    void build(int threads, const Scene* previous, const StopFn& stop);
    void check_media_apart(const std::vector<TriangleMesh>& quads, const Scene* previous);

    SceneDesc desc_;
    std::shared_ptr<const RayTracer> tracer_;
    std::vector<std::shared_ptr<const DistanceGrid>> grids_;
    std::vector<int> grid_resolutions_;
    std::vector<std::string> rebuilt_;
    std::vector<int> area_lights_;  // light index per extra Embree mesh
    // Opaque surfaces meeting media (medium, surface, how): kept for the pairs an edit
    // leaves as they were.
    std::vector<std::tuple<int, int, SurfaceContact>> contacts_;
    // Per shape, from contacts_.
    std::vector<TriangleMesh> obstacles_;
    std::vector<std::vector<bool>> touching_;
    std::vector<bool> lit_inside_;    // per shape: a point light lies inside its medium
    std::vector<float> light_scale_;  // per light (light_scale)
    std::vector<int> light_medium_;   // per light (light_medium)
    Bounds3 bounds_;                  // of every mesh the BVH holds
    int environment_ = -1;
    bool grey_ = true;
    bool has_surfaces_ = false;
};

}  // namespace sss

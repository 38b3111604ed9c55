// The buffer layouts the host and the shaders share, written once: included by C++
// (gpu/gpu_scene.h, gpu/gpu_renderer.cpp) and by GLSL (shaders/scene.glsl, render.glsl).
// Every member is a 16-byte vec4 / uvec4 / ivec4 (C++: float[4], uint32_t[4],
// int32_t[4]) or an array of them, so the std430 layout of the shaders is C++'s layout
// with no padding; the static_asserts at the end check that on the C++ side, and the
// shaders compile the very same declarations.
#ifndef SSS_GPU_LAYOUT_H
#define SSS_GPU_LAYOUT_H

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>

namespace sss {
namespace gpu_layout {
typedef float vec4[4];
typedef uint32_t uvec4[4];
typedef int32_t ivec4[4];
}  // namespace gpu_layout
using gpu_layout::ivec4;
using gpu_layout::uvec4;
using gpu_layout::vec4;
#define SSS_LAYOUT_CONST inline constexpr
#else
#define SSS_LAYOUT_CONST const
#ifndef uint32_t
#define uint32_t uint
#endif
#ifndef int32_t
#define int32_t int
#endif
#endif

SSS_LAYOUT_CONST int kGpuMaxShapes = 16;
SSS_LAYOUT_CONST int kGpuMaxEmitters = 16;
SSS_LAYOUT_CONST int kGpuMaxLights = 16;

// render.glsl's outputs: per path the radiance (vec4, rgb) and the counts (uvec2:
// ordinary scattering events, sphere steps | kGpuWritten). The host zeroes the counts
// before a dispatch and so finds paths that never ended (Mesa's lavapipe ends all loops
// of an invocation after 65535 iterations in all, silently; a GPU does not).
SSS_LAYOUT_CONST uint32_t kGpuWritten = 0x80000000u;

struct GpuShape {
    vec4 sigma_t;  // xyz: sigma_t per channel; w: "st"'s clearance (SphereTracing)
    // xyz: albedo; w: 1 where some triangle of the medium's mesh touches an opaque
    // surface (Scene::touches_surfaces), else 0
    vec4 albedo;
    vec4 boundary;  // render/boundaries/boundary.h's BoundaryData: x its type, yzw xyz
    vec4 phase;     // render/phase/phase.h's PhaseData: x its type, y, z x, y
    // render/surfaces/surface.h's SurfaceData: surface.x its type (-1: the shape holds a
    // medium), surface.y its x; surface_color.xyz its colour. surface.z: 1 where light
    // sampling at the medium's events can reach a light (Scene::medium_samples_lights)
    vec4 surface;
    vec4 surface_color;
};

struct GpuGrid {
    vec4 origin;  // xyz: node (0, 0, 0); w: cell size
    vec4 scale;   // x: 1 / cell; y: guard
    ivec4 n;      // nodes per axis; w: offset of node (0, 0, 0) in scene_floats
};

// A shape's plane certificates for cut sphere steps (geometry/cut_planes.h): cells of
// size origin.w from origin.xyz, n.xyz of them per axis; per cell an entry index (int32
// bits in scene_floats from n.w; -1: none) and per entry 8 floats from entries.x: the
// cell's centre, m, the unit normal, 0. params: x the balls' radius, y the guard, z the
// shape's smallest extinction, w 1 / cell size. n.x = 0: the shape takes no cut steps.
struct GpuCutGrid {
    vec4 origin;
    vec4 params;
    ivec4 n;
    ivec4 entries;
};

// A light (render/lights/light.h's LightData): a.xyz, b.xyz, c.xyz and value.rgb its
// vectors and colour, a.w its type id (render/lights/registry.h), b.w its scalar, value.w
// the medium a point light lies inside (Scene::light_medium; -1: none).
struct GpuLight {
    vec4 a, b, c, value;
};

// The scene header (binding 0): C++ struct GpuSceneHeader, GLSL buffer block SceneHeader.
// lighting: x the number of lights, y 1 when the shaders sample lights (NEE), z the
// number of point and directional ones (first in lights[]), w where the lights' table of
// floats starts in scene_floats. params.w: 1 for grey media.
// clang-format off
#define SSS_GPU_SCENE_HEADER_FIELDS                                                      \
    vec4 cam_origin;                /* w: tan(fov / 2) */                               \
    vec4 cam_forward;               /* w: aspect */                                     \
    vec4 cam_right;                 /* w: Scene::camera_ray_start */                    \
    vec4 cam_up;                                                                        \
    vec4 environment;               /* x: its index in lights; w: 1 if there is one */  \
    uvec4 counts;                   /* shapes, emitter meshes, width, height */         \
    vec4 params;                    /* unused, sphere threshold, sigma_max, grey */     \
    GpuShape shapes[kGpuMaxShapes];                                                     \
    GpuGrid grids[kGpuMaxShapes];                                                       \
    vec4 emitters[kGpuMaxEmitters]; /* mesh counts.x + i: rgb; w: index in lights */    \
    uvec4 lighting;                 /* lights, NEE, point + directional, floats */      \
    GpuLight lights[kGpuMaxLights];                                                     \
    vec4 cut_params;                /* x: the cut models' largest sigma; y: min depth */\
    GpuCutGrid cut_grids[kGpuMaxShapes];
// clang-format on

// render.glsl's push constants
#define SSS_GPU_RENDER_PUSH_FIELDS                                              \
    uint32_t seed_lo, seed_hi;                                                  \
    uint32_t sample0;    /* sample index of path 0 */                           \
    int32_t max_bounces; /* scattering events per path; < 0: no limit ("pt") */ \
    uint32_t num_paths;  /* paths of this dispatch */

#ifdef __cplusplus
struct GpuSceneHeader {
    SSS_GPU_SCENE_HEADER_FIELDS
};
struct GpuRenderPush {
    SSS_GPU_RENDER_PUSH_FIELDS
};

// std430 puts vec4s and structs of them 16 bytes apart, with no padding: so must C++.
static_assert(sizeof(vec4) == 16 && sizeof(uvec4) == 16 && sizeof(ivec4) == 16);
static_assert(sizeof(GpuShape) == 6 * 16 && sizeof(GpuGrid) == 3 * 16 &&
              sizeof(GpuLight) == 4 * 16 && sizeof(GpuCutGrid) == 4 * 16);
static_assert(offsetof(GpuSceneHeader, shapes) == 7 * 16);
static_assert(offsetof(GpuSceneHeader, grids) == (7 + 6 * kGpuMaxShapes) * 16);
static_assert(offsetof(GpuSceneHeader, emitters) == (7 + 9 * kGpuMaxShapes) * 16);
static_assert(offsetof(GpuSceneHeader, lighting) ==
              (7 + 9 * kGpuMaxShapes + kGpuMaxEmitters) * 16);
static_assert(offsetof(GpuSceneHeader, lights) ==
              (8 + 9 * kGpuMaxShapes + kGpuMaxEmitters) * 16);
static_assert(offsetof(GpuSceneHeader, cut_grids) ==
              (9 + 9 * kGpuMaxShapes + kGpuMaxEmitters + 4 * kGpuMaxLights) * 16);
static_assert(sizeof(GpuSceneHeader) ==
              (9 + 13 * kGpuMaxShapes + kGpuMaxEmitters + 4 * kGpuMaxLights) * 16);
static_assert(sizeof(GpuRenderPush) == 5 * 4);  // scalars: 4 bytes each in both
}  // namespace sss
#endif

#undef SSS_LAYOUT_CONST
#endif  // SSS_GPU_LAYOUT_H

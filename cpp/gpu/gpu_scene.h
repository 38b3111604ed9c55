// A scene as the GPU path reads it (cpp/gpu/shaders/scene.glsl): plain arrays, no Embree,
// no CGAL, so a renderer on another machine needs only this file's data and Vulkan. Built
// from a Scene (and the sphere-step models) by bake_gpu_scene (gpu_scene_bake.h); saved
// to and loaded from a binary file for `sssphere-gpu-bench`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "geometry/flat_bvh.h"

namespace sss {

constexpr int kGpuMaxShapes = 16;
constexpr int kGpuMaxEmitters = 16;
constexpr int kGpuMaxLights = 16;

// std430 mirrors of scene.glsl's structs (field comments there).
struct GpuShape {
    float sigma_t[4];   // xyz, w: g
    float albedo[4];    // xyz, w: 1 dielectric, 0 index-matched
    float boundary[4];  // x: ior
};
struct GpuGrid {
    float origin[4];  // xyz, w: cell size
    float scale[4];   // x: 1 / cell, y: guard
    int32_t n[4];     // nodes per axis, w: offset in grid_values
};
// A light for NEE (scene.glsl's GpuLight).
enum class GpuLightType : int { Point = 0, Directional = 1, Area = 2, Environment = 3 };
struct GpuLight {
    float a[4];         // xyz: point position, directional travel direction, area
                        // corner; w: GpuLightType
    float edge1[4];     // area: edge1
    float edge2[4];     // area: edge2; w: the quad's area
    float radiance[4];  // point: intensity; directional: irradiance; else radiance
};
struct GpuSceneHeader {
    float cam_origin[4];   // w: tan(fov / 2)
    float cam_forward[4];  // w: aspect
    float cam_right[4];
    float cam_up[4];
    float environment[4];  // rgb, w: 1 if present
    uint32_t counts[4];    // shapes, emitter meshes, width, height
    float params[4];       // unused, sphere threshold, sigma_max, grey media (1/0)
    GpuShape shapes[kGpuMaxShapes];
    GpuGrid grids[kGpuMaxShapes];
    float emitters[kGpuMaxEmitters][4];  // rgb radiance, w: its index in lights
    // x: lights; y: 1 when the shaders sample lights (NEE); z: the point and directional
    // ones, first in lights[]
    uint32_t lighting[4];
    GpuLight lights[kGpuMaxLights];
    float event_phi[4];  // x, y: EventGen's range of phi (an event's albedo is clamped)
};

// Packed decoders (model.glsl): decoder d (0 LengthGen, 1 PathGen, 2 EventGen) has a
// header of kGpuDecoderHeader floats at d * kGpuDecoderHeader: [0] layers, [1]
// input_width, [2] latent_dim, [3] conditions, [4] outputs; layer l at [8 + 4l]: in, out,
// softplus (1/0), offset of its row-major weights (the bias follows them); the encoding
// of condition i at [32 + 8i] and of output o at [32 + 8(7 + o)]: kind (0 affine, 1 log,
// 2 logit), a, b, s, c, lo, hi, eps. Weights follow the three headers.
// The GPU decoders have two hidden layers (paper Table 1) of at most kGpuMaxWidth units.
constexpr int kGpuDecoderHeader = 160;
constexpr int kGpuLayers = 3;
constexpr int kGpuMaxWidth = 16;
// The shaders read the packed decoders from a uniform block of this many floats.
constexpr int kGpuModelFloats = 4096;

struct GpuSceneData {
    std::string source;  // the scene file, for messages
    GpuSceneHeader header{};
    std::vector<FlatBvhNode> nodes;
    std::vector<FlatTriangle> triangles;
    std::vector<float> grid_values;
    std::vector<float> model;  // packed decoders; empty when the scene has no models
    int width() const { return int(header.counts[2]); }
    int height() const { return int(header.counts[3]); }
};

// The specialization constants of model.glsl for packed decoders (LengthGen's input
// width, hidden widths and latent dimension, then PathGen's and EventGen's); the Table 1
// shapes when `model` is empty (no steps are taken then).
std::vector<int32_t> gpu_model_constants(const std::vector<float>& model);

// Binary file: magic "SSSGPU02" (01: before NEE, refused), then the header and the four
// arrays (each a uint64 count then its elements), little-endian as in memory. Errors name
// the file.
void save_gpu_scene(const GpuSceneData& scene, const std::string& path);
GpuSceneData load_gpu_scene(const std::string& path);

}  // namespace sss

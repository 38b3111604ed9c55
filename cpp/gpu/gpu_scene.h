// A scene as the GPU path reads it (cpp/gpu/shaders/scene.glsl): plain arrays, no Embree,
// no CGAL, so a renderer on another machine needs only this file's data and Vulkan. Built
// from a Scene (and the sphere-step models) by bake_gpu_scene (gpu_scene_bake.h); saved
// to and loaded from a binary file for `sssphere-gpu-bench`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "geometry/flat_bvh.h"
#include "gpu/shaders/layout.h"

namespace sss {

// The buffer layouts (GpuSceneHeader, GpuShape, GpuGrid, GpuLight, kGpuMax*) are
// written once for C++ and GLSL in shaders/layout.h.

// Packed decoders (model.glsl): decoder d (0 LengthGen, 1 PathGen, 2 EventGen) has a
// header of kGpuDecoderHeader floats at d * kGpuDecoderHeader: [0] layers, [1]
// input_width, [2] latent_dim, [3] conditions, [4] outputs, and in PathGen's header [5]
// where the forward-memory tilt starts (0: none; model.glsl, tilt_at), [6] and [7] its
// counts of nodes of sigma and g; layer l at [8 + 4l]: in, out,
// softplus (1/0), offset of its row-major weights (the bias follows them); the encoding
// of condition i at [32 + 8i] and of output o at [32 + 8(7 + o)]: kind (0 affine, 1 log,
// 2 logit), a, b, s, c, lo, hi, eps. Weights follow the three headers.
// The GPU decoders have two hidden layers (paper Table 1) of at most kGpuMaxWidth units.
constexpr int kGpuDecoderHeader = 160;
constexpr int kGpuLayers = 3;
constexpr int kGpuMaxWidth = 16;
// The cut step's decoders (cut_model.glsl) may be wider, and have a uniform block of
// their own of this many floats.
constexpr int kGpuCutMaxWidth = 32;
constexpr int kGpuCutModelFloats = 4096;
// The shaders read the packed decoders from a uniform block of this many floats.
constexpr int kGpuModelFloats = 4096;

struct GpuSceneData {
    std::string source;  // the scene file, for messages
    GpuSceneHeader header{};
    std::vector<FlatBvhNode> nodes;
    std::vector<FlatTriangle> triangles;
    // The distance grids (GpuGrid.n.w: where each starts), then the lights' table of
    // floats (SceneDesc::light_floats; header.lighting.w: where it starts).
    std::vector<float> floats;
    std::vector<float> model;  // packed decoders; empty when the scene has no models
    // packed cut decoders (pack_gpu_cut_model); empty when the scene takes no cut steps
    std::vector<float> cut_model;
    // What a render of it should say (SphereTracing::warnings); not saved to files.
    std::vector<std::string> warnings;
    int width() const { return int(header.counts[2]); }
    int height() const { return int(header.counts[3]); }
};

// The specialization constants of model.glsl for packed decoders (LengthGen's input
// width, hidden widths and latent dimension, then PathGen's and EventGen's); the Table 1
// shapes when `model` is empty (no steps are taken then).
std::vector<int32_t> gpu_model_constants(const std::vector<float>& model);
// The same for cut_model.glsl's packed cut decoders (CutLengthGen's input width, hidden
// widths and latent dimension, then CutPathGen's); some valid shapes when it is empty.
std::vector<int32_t> gpu_cut_model_constants(const std::vector<float>& cut_model);

// Binary file: magic "SSSGPU08" (01: before NEE, 02: before render/lights/, 03: before
// render/surfaces/, 04: before cut steps, 05: before exact contact, whose triangles
// lack the touching flag and whose camera lacks its ray start, 06: before point lights
// inside dielectric media, which its shapes and lights do not mark, 07: before lights
// name the medium they lie in (value.w); refused),
// then the header and the five arrays (each a uint64 count then its elements),
// little-endian as in memory. Errors name the file.
void save_gpu_scene(const GpuSceneData& scene, const std::string& path);
GpuSceneData load_gpu_scene(const std::string& path);

}  // namespace sss

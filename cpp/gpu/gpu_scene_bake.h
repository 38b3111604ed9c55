// From a built Scene to the GPU path's plain arrays (gpu_scene.h): the flattened BVH, the
// distance grids, the media, lights and camera, and (for "st") the packed decoders.
#pragma once

#include <string>

#include "gpu/gpu_scene.h"
#include "render/scene.h"

namespace sss {

class CutStepModel;
class ScatteringModel;

// The decoders in the layout of gpu_scene.h ("Packed decoders"); throws sss::Error when
// they are larger than the GPU path supports.
std::vector<float> pack_gpu_model(const ScatteringModel& model);
// CutLengthGen and CutPathGen in the same layout (two decoders, layers of at most
// kGpuCutMaxWidth units), for cut_model.glsl.
std::vector<float> pack_gpu_cut_model(const CutStepModel& model);

// Checks that the GPU path can render `scene` as asked and throws sss::Error naming the
// field and what is allowed otherwise: at most kGpuMaxShapes shapes and kGpuMaxLights
// lights. With nee the shaders sample the lights as pt.cpp does, where a medium has an
// index-matched boundary (elsewhere no shadow ray leaves it), and "st" steps keep their
// clearance from point and directional lights (StepNee::Hits). With integrator "st",
// `models` is the decoders' directory, checked against the media as SphereTracing does;
// `cut_models` (empty: none) the cut sphere models' directory: the media SphereTracing
// gives cut steps get their plane certificates (GpuSceneHeader::cut_grids) and the
// shaders the packed cut decoders.
GpuSceneData bake_gpu_scene(const Scene& scene, const std::string& integrator, bool nee,
                            float sphere_threshold, const std::string& models,
                            const std::string& cut_models = "");

}  // namespace sss

// The scene's buffers (gpu/shaders/layout.h lays them out, gpu/gpu_scene.h fills them),
// declared apart from scene.glsl so that a shader can declare them before math.glsl: the
// light types read the lights' table of floats from them (SSS_LIGHT_FLOAT,
// render/lights/light.h).
#ifndef SSS_GPU_SCENE_BUFFERS_GLSL
#define SSS_GPU_SCENE_BUFFERS_GLSL

#include "gpu/shaders/layout.h"

// GpuShape, GpuGrid, GpuLight and the header's fields: gpu/shaders/layout.h
layout(std430, binding = 0) readonly buffer SceneHeader { SSS_GPU_SCENE_HEADER_FIELDS };
layout(std430, binding = 1) readonly buffer BvhNodes { vec4 nodes[]; };
layout(std430, binding = 2) readonly buffer BvhTriangles { vec4 triangles[]; };
// The distance grids, then the lights' table of floats from lighting.w on.
layout(std430, binding = 3) readonly buffer SceneFloats { float scene_floats[]; };

#undef SSS_LIGHT_FLOAT
#define SSS_LIGHT_FLOAT(i) scene_floats[lighting.w + uint(i)]

#endif  // SSS_GPU_SCENE_BUFFERS_GLSL

#version 450
// Sphere steps sampled by the GPU's decoders for per-item (sigma, g): item i draws from
// Rng(seed, i, 0), as ScatteringModel::sample_batch does, so tests compare the two.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

layout(local_size_x = 64) in;

#include "gpu/shaders/rng.glsl"
#include "gpu/shaders/math.glsl"

const int kModelVec4 = 1024;  // kGpuModelFloats / 4
layout(std140, binding = 0) uniform Model { vec4 model_v[kModelVec4]; };
layout(std430, binding = 1) readonly buffer Inputs { vec2 inputs[]; };  // sigma, g
layout(std430, binding = 2) writeonly buffer Outputs { vec4 outputs[]; };  // N, cos, a, b

layout(push_constant) uniform Push {
    uint seed_lo, seed_hi, count;
};

#include "gpu/shaders/model.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    Rng rng = rng_make((uint64_t(seed_hi) << 32) | uint64_t(seed_lo), uint64_t(i), 0ul);
    SphereStepSample s = sample_sphere_step(inputs[i].x, inputs[i].y, rng);
    outputs[i] = vec4(s.N, s.cos_theta, s.alpha, s.beta);
}

#version 450
// Sphere steps sampled by the GPU's decoders for per-item (sigma, g, phi), with EventGen's
// event if with_event: item i draws from rng_make(seed, i, 0), as ScatteringModel::sample_batch
// does, so tests compare the two.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

layout(local_size_x = 64) in;

#include "gpu/shaders/math.glsl"

const int kModelVec4 = 1024;  // kGpuModelFloats / 4
layout(std140, binding = 0) uniform Model { vec4 model_v[kModelVec4]; };
layout(std430, binding = 1) readonly buffer Inputs { vec4 inputs[]; };  // sigma, g, phi
// Per item: (N, cos_theta, alpha, beta), (X, 0), (W, 0).
layout(std430, binding = 2) writeonly buffer Outputs { vec4 outputs[]; };

layout(push_constant) uniform Push {
    uint seed_lo, seed_hi, count, with_event;
};

#include "gpu/shaders/model.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    RngState rng = rng_make((uint64_t(seed_hi) << 32) | uint64_t(seed_lo), uint64_t(i), 0ul);
    vec4 in_i = inputs[i];
    SphereStepSample s = sample_sphere_step(in_i.x, in_i.y, in_i.z, with_event != 0u, rng);
    outputs[3 * i] = vec4(s.N, s.cos_theta, s.alpha, s.beta);
    outputs[3 * i + 1] = vec4(s.X, 0.0);
    outputs[3 * i + 2] = vec4(s.W, 0.0);
}

#version 450
// Cut sphere steps sampled by the GPU's decoders for per-item (sigma, g, h, mu0): item i
// draws from rng_make(seed, i, 0), as the binding's cut_steps (CutStepModel::sample_group)
// does, so tests compare the two.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

layout(local_size_x = 64) in;

#include "gpu/shaders/math.glsl"

const int kCutVec4 = 1024;  // kGpuCutModelFloats / 4
layout(std140, binding = 0) uniform CutModel { vec4 cut_v[kCutVec4]; };
layout(std430, binding = 1) readonly buffer Inputs { vec4 inputs[]; };  // sigma, g, h, mu0
// Per item: (N, through_plane, 0, 0), (exit_pos, 0), (exit_dir, 0).
layout(std430, binding = 2) writeonly buffer Outputs { vec4 outputs[]; };

layout(push_constant) uniform Push { uint seed_lo, seed_hi, count; };

#include "gpu/shaders/cut_model.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    RngState rng = rng_make((uint64_t(seed_hi) << 32) | uint64_t(seed_lo), uint64_t(i), 0ul);
    vec4 in_i = inputs[i];
    CutStepSample s = sample_cut_step(in_i.x, in_i.y, in_i.z, in_i.w, rng);
    outputs[3 * i] = vec4(s.N, s.through_plane ? 1.0 : 0.0, 0.0, 0.0);
    outputs[3 * i + 1] = vec4(s.exit_pos, 0.0);
    outputs[3 * i + 2] = vec4(s.exit_dir, 0.0);
}

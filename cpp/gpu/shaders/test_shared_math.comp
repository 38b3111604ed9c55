// The portable maths (core/frame.h, cpp/shared/) evaluated on the GPU for the cases of
// cpp/gpu/shared_math_test.cpp, which compares them with the same functions compiled as C++:
// the check on what portable.glsl supplies (log1p, expm1, copysign) and on the GPU's float
// maths where the CPU computes in double.
#version 450
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu/shaders/math.glsl"

layout(local_size_x = 64) in;

// Per case, kIn inputs and kOut outputs, in the order of shared_math_test.cpp.
const uint kIn = 15, kOut = 24;
layout(std430, set = 0, binding = 0) readonly buffer In { float v[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Out { float o[]; };

layout(push_constant) uniform Push { uint n; };

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= n) return;
    const uint a = kIn * i, b = kOut * i;
    const float c = v[a], g = v[a + 1], u1 = v[a + 2], u2 = v[a + 3], cos_i = v[a + 4],
                eta = v[a + 5], sigma = v[a + 6], x = v[a + 7], phi = v[a + 8],
                n_events = v[a + 9], alpha = v[a + 10], beta = v[a + 11];
    const vec3 p = vec3(v[a + 12], v[a + 13], v[a + 14]);
    o[b] = hg_eval(c, g);
    o[b + 1] = hg_sample_cos(u1, g);
    const vec3 wi = sample_uniform_sphere(u2, u1);
    const vec3 w = hg_sample(wi, g, u1, u2);
    o[b + 2] = w.x, o[b + 3] = w.y, o[b + 4] = w.z;
    float cos_t;
    o[b + 5] = fresnel_dielectric(cos_i, eta, cos_t);
    o[b + 6] = cos_t;
    o[b + 7] = sample_exponential(u1, sigma);
    o[b + 8] = softplus(x);
    o[b + 9] = survival_power(phi, n_events);
    o[b + 10] = event_weight_sum(phi, n_events);
    o[b + 11] = first_event_probability(phi, n_events);
    const vec3 e = frame_to_world(sphere_step_frame(wi, u2), sphere_exit_direction(c, alpha, beta));
    o[b + 12] = e.x, o[b + 13] = e.y, o[b + 14] = e.z;
    o[b + 15] = expm1(x * 1e-3) * copysign(1.0, c);
    float pa = p.x, pb = p.y;
    project_into_disc(pa, pb);
    o[b + 16] = pa, o[b + 17] = pb;
    const vec3 ball = project_into_ball(p), unit = unit_or_z(p);
    o[b + 18] = ball.x, o[b + 19] = ball.y, o[b + 20] = ball.z;
    o[b + 21] = unit.x, o[b + 22] = unit.y, o[b + 23] = unit.z;
}

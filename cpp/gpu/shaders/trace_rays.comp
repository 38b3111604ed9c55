#version 450
// Closest hits of a batch of rays against the scene's BVH (scene.glsl), for tests that
// compare them with Embree's.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 64) in;

#include "gpu/shaders/math.glsl"
#include "gpu/shaders/scene.glsl"

// Ray i: origin rays[2i].xyz, unit direction rays[2i + 1].xyz, tfar rays[2i + 1].w.
layout(std430, binding = 4) readonly buffer Rays { vec4 rays[]; };
// Hit i: t (or -1 for none), the mesh index as float bits, the normal's x and y.
layout(std430, binding = 5) writeonly buffer Hits { vec4 hits[]; };

layout(push_constant) uniform Push { uint count; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    Hit h;
    vec4 o = rays[2 * i], d = rays[2 * i + 1];
    if (intersect(o.xyz, d.xyz, d.w, h))
        hits[i] = vec4(h.t, uintBitsToFloat(h.mesh), h.normal.x, h.normal.y);
    else
        hits[i] = vec4(-1.0, 0.0, 0.0, 0.0);
}

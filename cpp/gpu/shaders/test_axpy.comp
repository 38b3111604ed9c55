// y[i] = a * x[i] + y[i] for i < n: the test shader of VulkanCompute
// (cpp/gpu/vulkan_compute_test.cpp). The flat index is a 64-bit integer so that the
// shaderInt64 feature the renderer relies on is exercised; a 2D dispatch covers n beyond
// maxComputeWorkGroupCount[0] * 64.
#version 450
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer X { float x[]; };
layout(std430, set = 0, binding = 1) buffer Y { float y[]; };

layout(push_constant) uniform Push {
    float a;
    uint n;
};

void main() {
    const uint64_t row = uint64_t(gl_NumWorkGroups.x) * uint64_t(gl_WorkGroupSize.x);
    const uint64_t i = uint64_t(gl_GlobalInvocationID.y) * row + gl_GlobalInvocationID.x;
    if (i >= uint64_t(n)) return;
    y[uint(i)] = a * x[uint(i)] + y[uint(i)];
}

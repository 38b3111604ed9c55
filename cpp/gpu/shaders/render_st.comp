#version 450
// Integrator "st" on the GPU (render.glsl).
#define SSS_ST 1
#include "gpu/shaders/render.glsl"

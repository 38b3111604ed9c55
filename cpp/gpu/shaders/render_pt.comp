#version 450
// Integrator "pt" on the GPU (render.glsl).
#define SSS_ST 0
#include "gpu/shaders/render.glsl"

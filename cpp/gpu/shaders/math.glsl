// The CPU's random streams and scattering maths (core/rng.h, core/frame.h and
// cpp/shared/: PCG32, HG, Fresnel, free flights, roulette, MIS, Softplus, the sphere
// step's frame, exit and weights) and the registered lights, boundaries, phase functions
// and surfaces, compiled from the same headers through portable.glsl.
// Needs GL_EXT_shader_explicit_arithmetic_types_int64 (the streams' 64-bit state).

#include "gpu/shaders/portable.glsl"

#include "core/frame.h"
#include "core/rng.h"
#include "shared/fresnel.h"
#include "shared/hg.h"
#include "shared/path.h"
#include "shared/ray_offset.h"
#include "shared/sampling.h"
#include "shared/softplus.h"
#include "shared/sphere_step.h"
#include "render/boundaries/registry.h"
#include "render/lights/registry.h"
#include "render/phase/registry.h"
#include "render/surfaces/registry.h"


// The learned cut sphere step (cpp/nn/cut_step_model.h) on the GPU: CutLengthGen and
// CutPathGen evaluated per invocation from the packed decoders in `cut_f`
// (gpu_scene_bake.h's pack_gpu_cut_model: decoder_common.glsl's layout, two decoders),
// consuming the random stream as CutStepModel::sample does, so that a stream gives the
// same step on both up to float rounding (tests/test_gpu.py compares them).
// The includer declares the uniform block `vec4 cut_v[kCutVec4]` (the packed floats, four
// per vec4; kGpuCutModelFloats) first, includes math.glsl, and enables
// GL_EXT_control_flow_attributes.
//
// The decoders' shapes are specialization constants (ids 13-20, after model.glsl's and
// render.glsl's; the host sets them from the packed decoders: gpu_cut_model_constants), so
// the driver unrolls the loops below: Mesa's lavapipe ends all loops of an invocation
// after 65535 iterations in all, which a path of a few dozen cut steps would reach with
// loops left rolled.

#include "gpu/shaders/decoder_common.glsl"
#include "shared/cut_step.h"

layout(constant_id = 13) const int CL_IN = 4;   // CutLengthGen: input width
layout(constant_id = 14) const int CL_H1 = 8;   //   hidden widths
layout(constant_id = 15) const int CL_H2 = 8;
layout(constant_id = 16) const int CL_LAT = 2;  //   latent dimension (1 output)
layout(constant_id = 17) const int CP_IN = 5;   // CutPathGen
layout(constant_id = 18) const int CP_H1 = 8;
layout(constant_id = 19) const int CP_H2 = 8;
layout(constant_id = 20) const int CP_LAT = 4;  //   (4 outputs)

const int kCutLengthGen = 0, kCutPathGen = 1;
const int kCutW = 32;  // the widest layer or input (kGpuCutMaxWidth, checked on the host)

float cval(int i) { return cut_v[i >> 2][i & 3]; }

// Where each layer's weights start (its bias follows them), as pack_gpu_cut_model lays
// them out after the two headers: constants once the shapes are specialized (checked on
// the host: gpu_cut_model_constants).
const int kCL0 = 2 * kDecoderHeader;
const int kCL1 = kCL0 + CL_IN * CL_H1 + CL_H1;
const int kCL2 = kCL1 + CL_H1 * CL_H2 + CL_H2;
const int kCP0 = kCL2 + CL_H2 * 2 + 2;  // CutLengthGen's last layer: mean and log-variance
const int kCP1 = kCP0 + CP_IN * CP_H1 + CP_H1;
const int kCP2 = kCP1 + CP_H1 * CP_H2 + CP_H2;

// Condition i (decode false) or output o (decode true) of decoder d.
float cut_code(int d, int i, float x, bool decode) {
    int at = d * kDecoderHeader + 32 + 8 * (decode ? 7 + i : i);
    return code_value(cval(at), cval(at + 1), cval(at + 2), cval(at + 3), cval(at + 4),
                      cval(at + 5), cval(at + 6), cval(at + 7), x, decode);
}

// b = act(W a + bias) for the layer whose weights start at w, n_in -> n_out (constants
// after specialization: the guards fold away).
void cut_dense(int w, int n_in, int n_out, bool act, float a[kCutW], out float b[kCutW]) {
    int bias = w + n_in * n_out;
    [[unroll]] for (int o = 0; o < kCutW; ++o) {
        float acc = 0.0;
        if (o < n_out) {
            acc = cval(bias + o);
            [[unroll]] for (int i = 0; i < kCutW; ++i)
                if (i < n_in) acc += cval(w + o * n_in + i) * a[i];
            if (act) acc = softplus(acc);
        }
        b[o] = acc;
    }
}

// The decoder whose layers start at w0, w1 and w2 (input n_in, hidden h1 and h2 wide, n_out
// outputs) on its encoded input x: the outputs (at most 4) u_o = mean_o + exp(logvar_o / 2)
// eps_o, the exponent capped at 88 as the CPU's lanes cap it, and made finite (0
// otherwise) as CutStepModel does.
void cut_decoder_sample(int w0, int w1, int w2, int n_in, int h1, int h2, int n_out,
                        float x[kCutW], float eps[4], out float u[4]) {
    float a[kCutW], b[kCutW];
    cut_dense(w0, n_in, h1, true, x, a);
    cut_dense(w1, h1, h2, true, a, b);
    cut_dense(w2, h2, 2 * n_out, false, b, a);
    [[unroll]] for (int o = 0; o < 4; ++o)
        u[o] = o < n_out ? finite_or(a[o] + exp(min(0.5 * a[n_out + o], 88.0)) * eps[o], 0.0)
                         : 0.0;
}

struct CutStepSample {
    float N;  // events (>= 1; an integer, exact in float up to 2^24 and rounded beyond)
    bool through_plane;
    vec3 exit_pos, exit_dir;  // in the walk's frame (the unit ball, the plane z = h)
};

// One cut step for optical radius sigma, anisotropy g, the plane at h and the arriving
// direction's cosine mu0 with the plane's normal (CutStepModel::sample_group, one path).
CutStepSample sample_cut_step(float sigma, float g, float h, float mu0, inout RngState rng) {
    CutStepSample s;
    s.N = 1.0;
    // 1. The first flight, exactly: leaving the region before it scatters is N = 1.
    vec3 w_in = vec3(sqrt(max(0.0, 1.0 - mu0 * mu0)), 0.0, mu0);
    float u1 = rng_uniform(rng), u2 = rng_uniform(rng);
    vec3 w = hg_sample(w_in, g, u1, u2);
    float t = -log1p(-rng_uniform(rng)) / sigma;
    vec3 P = w, D = w;
    if (!(t >= cut_first_exit(w, h))) {
        // 2. The networks: CutLengthGen's latent and noise, then CutPathGen's.
        const int nl = CL_LAT, np = CP_LAT;
        float z[16];
        draw_normals(rng, nl + 1 + np + 4, z);
        float x[kCutW], eps[4], u[4];
        float cond[4] = float[4](sigma, g, h, mu0);
        [[unroll]] for (int i = 0; i < kCutW; ++i) x[i] = 0.0;
        [[unroll]] for (int i = 0; i < 4; ++i) x[i] = cut_code(kCutLengthGen, i, cond[i], false);
        [[unroll]] for (int i = 0; i < kCutW - 4; ++i)
            if (i < nl) x[4 + i] = z[i];
        eps[0] = z[nl];
        eps[1] = eps[2] = eps[3] = 0.0;
        cut_decoder_sample(kCL0, kCL1, kCL2, CL_IN, CL_H1, CL_H2, 1, x, eps, u);
        float n_raw = finite_or(cut_code(kCutLengthGen, 0, u[0], true), 2.0);
        s.N = clamp(floor(n_raw), 2.0, kMaxScatterCount);

        [[unroll]] for (int i = 0; i < kCutW; ++i) x[i] = 0.0;
        [[unroll]] for (int i = 0; i < 4; ++i) x[i] = cut_code(kCutPathGen, i, cond[i], false);
        x[4] = cut_code(kCutPathGen, 4, s.N, false);
        [[unroll]] for (int i = 0; i < kCutW - 5; ++i)
            if (i < np) x[5 + i] = z[nl + 1 + i];
        [[unroll]] for (int o = 0; o < 4; ++o) eps[o] = z[nl + 1 + np + o];
        cut_decoder_sample(kCP0, kCP1, kCP2, CP_IN, CP_H1, CP_H2, 4, x, eps, u);
        float cos_p = clamp(finite_or(cut_code(kCutPathGen, 0, u[0], true), 1.0), -1.0, 1.0);
        float cos_psi = clamp(finite_or(cut_code(kCutPathGen, 1, u[1], true), 1.0), -1.0, 1.0);
        float alpha = finite_or(cut_code(kCutPathGen, 2, u[2], true), 0.0);
        float beta = finite_or(cut_code(kCutPathGen, 3, u[3], true), 0.0);
        project_into_disc(alpha, beta);  // shared/sphere_step.h
        cut_network_exit(cos_p, cos_psi, alpha, beta, h, P, D);  // shared/cut_step.h
        if (rng_uniform(rng) < 0.5) {  // the mirror image in y (the networks' half)
            P.y = -P.y;
            D.y = -D.y;
        }
    }
    // 3. The exit point in direction P and the direction made to leave there.
    CutExit e = cut_exit(P, D, h);
    s.through_plane = e.through_plane;
    s.exit_pos = e.pos;
    s.exit_dir = e.dir;
    return s;
}

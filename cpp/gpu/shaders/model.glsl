// The learned sphere step (cpp/nn/scattering_model.h) on the GPU: LengthGen, PathGen and,
// when asked, EventGen evaluated per invocation from the packed decoders in `model`
// (layout: gpu_scene.h, "Packed decoders"), consuming the random stream exactly as ScatteringModel's
// step does, so a stream gives the same step on both up to float rounding
// (tests/test_gpu.py compares them).
// The includer declares the uniform block `vec4 model_v[kModelVec4]` (the packed floats,
// four per vec4) first, and enables GL_EXT_control_flow_attributes. A uniform block: every
// invocation reads the same weights, which NVIDIA's compiler then takes straight from its
// constant cache as operands.

#include "gpu/shaders/decoder_common.glsl"

// The decoders' shapes are specialization constants (set by the host from the model
// file, gpu_renderer.cpp), so the driver compiles the loops below unrolled and keeps the
// activations in registers: two hidden layers (paper Table 1), each at most kW wide.
layout(constant_id = 0) const int L_IN = 4;   // LengthGen: input width
layout(constant_id = 1) const int L_H1 = 8;   //   hidden widths
layout(constant_id = 2) const int L_H2 = 8;
layout(constant_id = 3) const int L_LAT = 2;  //   latent dimension (1 output)
layout(constant_id = 4) const int P_IN = 8;   // PathGen
layout(constant_id = 5) const int P_H1 = 16;
layout(constant_id = 6) const int P_H2 = 16;
layout(constant_id = 7) const int P_LAT = 5;  //   (3 outputs)
layout(constant_id = 8) const int E_IN = 12;  // EventGen
layout(constant_id = 9) const int E_H1 = 16;
layout(constant_id = 10) const int E_H2 = 16;
layout(constant_id = 11) const int E_LAT = 5;  //   (6 outputs)

const int kLengthGen = 0, kPathGen = 1, kEventGen = 2;
const int kW = 16;  // the widest layer or input (checked on the host)

float mval(int i) { return model_v[i >> 2][i & 3]; }
int mhead(int d, int i) { return int(mval(d * kDecoderHeader + i)); }

// Where each layer's weights start (its bias follows them), as pack_gpu_model lays them
// out: constants once the shapes are specialized (checked on the host).
const int kL0 = 3 * kDecoderHeader;
const int kL1 = kL0 + L_IN * L_H1 + L_H1;
const int kL2 = kL1 + L_H1 * L_H2 + L_H2;
const int kP0 = kL2 + L_H2 * 2 + 2;  // LengthGen's last layer: mean and log-variance of N
const int kP1 = kP0 + P_IN * P_H1 + P_H1;
const int kP2 = kP1 + P_H1 * P_H2 + P_H2;
const int kE0 = kP2 + P_H2 * 6 + 6;  // PathGen's last layer: 3 means, 3 log-variances
const int kE1 = kE0 + E_IN * E_H1 + E_H1;
const int kE2 = kE1 + E_H1 * E_H2 + E_H2;

// e(x) (decode false) or its inverse; the encoding's 8 floats start at `at`.
float code(int at, float x, bool decode) {
    return code_value(mval(at), mval(at + 1), mval(at + 2), mval(at + 3), mval(at + 4),
                      mval(at + 5), mval(at + 6), mval(at + 7), x, decode);
}
int condition_code(int d, int i) { return d * kDecoderHeader + 32 + 8 * i; }
int output_code(int d, int o) { return d * kDecoderHeader + 32 + 8 * (7 + o); }

// b = act(W a + bias) for the layer whose weights start at w, n_in -> n_out (constants
// after specialization: the guards fold away).
void dense(int w, int n_in, int n_out, bool act, float a[kW], out float b[kW]) {
    int bias = w + n_in * n_out;
    [[unroll]] for (int o = 0; o < kW; ++o) {
        float acc = 0.0;
        if (o < n_out) {
            acc = mval(bias + o);
            [[unroll]] for (int i = 0; i < kW; ++i)
                if (i < n_in) acc += mval(w + o * n_in + i) * a[i];
            if (act) acc = softplus(acc);
        }
        b[o] = acc;
    }
}

// A decoder's three layers (weights at w0, w1, w2) on x: the outputs (at most 6)
// u_o = mean_o + exp(logvar_o / 2) eps_o.
void decoder_sample(int w0, int w1, int w2, int n_in, int h1, int h2, int n_out,
                    float x[kW], float eps[6], out float u[6]) {
    float a[kW], b[kW];
    dense(w0, n_in, h1, true, x, a);
    dense(w1, h1, h2, true, a, b);
    dense(w2, h2, 2 * n_out, false, b, a);
    [[unroll]] for (int o = 0; o < 6; ++o)
        u[o] = o < n_out ? a[o] + exp(0.5 * a[n_out + o]) * eps[o] : 0.0;
}

// Node coordinate of x between the n increasing nodes at `at`: index i and fraction t in
// [0, 1], clamped at both ends (nn/step_tilt.cpp's locate).
void tilt_locate(int at, int n, float x, out int i, out float t) {
    i = 0;
    t = 0.0;
    if (n == 1 || !(x > mval(at))) return;
    while (i + 2 < n && x >= mval(at + i + 1)) ++i;
    t = min(1.0, (x - mval(at + i)) / (mval(at + i + 1) - mval(at + i)));
}

// The table at `at` (rows of ns values, one row per node of g) between rows k and k1 and
// columns i and i1, bilinearly.
float tilt_lerp(int at, int ns, int i, int i1, float t, int k, int k1, float u) {
    float lo = mval(at + k * ns + i) + t * (mval(at + k * ns + i1) - mval(at + k * ns + i));
    float hi = mval(at + k1 * ns + i) + t * (mval(at + k1 * ns + i1) - mval(at + k1 * ns + i));
    return lo + u * (hi - lo);
}

// PathGen's forward-memory tilt (a, b) at (sigma, g) (nn/step_tilt.h, StepTilt::at); false
// when the model has none.
bool tilt_at(float sigma, float g, out float a, out float b) {
    a = 0.0;
    b = 0.0;
    int at = mhead(kPathGen, 5), ns = mhead(kPathGen, 6), ng = mhead(kPathGen, 7);
    if (at == 0) return false;
    int i, k;
    float t, u;
    tilt_locate(at, ns, log(sigma), i, t);
    tilt_locate(at + ns, ng, g, k, u);
    int i1 = min(i + 1, ns - 1), k1 = min(k + 1, ng - 1);
    a = tilt_lerp(at + ns + ng, ns, i, i1, t, k, k1, u);
    b = tilt_lerp(at + ns + ng + ns * ng, ns, i, i1, t, k, k1, u);
    return true;
}

struct SphereStepSample {
    float N;  // events (>= 1; an integer, exact in float up to 2^24 and rounded beyond)
    float cos_theta, alpha, beta;
    // The representative event in the step's frame (EventGen; with_event only): |X| <= 1,
    // W unit; X = 0 and W = +z for the first event, at the centre.
    vec3 X, W;
};

// One step for optical radius sigma and anisotropy g, in the exit frame; with_event also
// draws the representative event for albedo phi.
SphereStepSample sample_sphere_step(float sigma, float g, float phi, bool with_event,
                                    inout RngState rng) {
    SphereStepSample s;
    s.N = 1.0;
    s.cos_theta = 1.0;
    s.alpha = 0.0;
    s.beta = 0.0;
    s.X = vec3(0.0);
    s.W = vec3(0.0, 0.0, 1.0);
    // N = 1 exactly with probability e^{-sigma}.
    if (rng_uniform(rng) < exp(-sigma)) {
        s.cos_theta = hg_sample_cos(rng_uniform(rng), g);
        return s;
    }
    // The normals: LengthGen's and PathGen's (z, eps, z, eps), then, once the step is
    // kept, EventGen's (z, eps).
    float z[16], ze[16];
    draw_normals(rng, L_LAT + 1 + P_LAT + 3, z);

    float ta, tb;
    bool tilted = tilt_at(sigma, g, ta, tb);
    float x[kW], eps[6], u[6];
    // LengthGen and PathGen, drawn again while the tilt refuses the step (at most
    // kTiltMaxDraws draws, the last kept; shared/sphere_step.h).
    for (int draw = 1;; ++draw) {
        // LengthGen(sigma, g) -> N = max(2, floor(x))
        [[unroll]] for (int i = 0; i < kW; ++i) x[i] = 0.0;
        [[unroll]] for (int o = 0; o < 6; ++o) eps[o] = 0.0;
        x[0] = code(condition_code(kLengthGen, 0), sigma, false);
        x[1] = code(condition_code(kLengthGen, 1), g, false);
        [[unroll]] for (int l = 0; l < kW - 2; ++l)
            if (l < L_LAT) x[2 + l] = z[l];
        eps[0] = z[L_LAT];
        decoder_sample(kL0, kL1, kL2, L_IN, L_H1, L_H2, 1, x, eps, u);
        float n_real = code(output_code(kLengthGen, 0), u[0], true);
        s.N = n_real >= 2.0 ? (n_real < kMaxScatterCount ? floor(n_real) : kMaxScatterCount)
                            : 2.0;

        // PathGen(sigma, g, N) -> cos_theta clamped, (alpha, beta) into the unit disc
        [[unroll]] for (int i = 0; i < kW; ++i) x[i] = 0.0;
        x[0] = code(condition_code(kPathGen, 0), sigma, false);
        x[1] = code(condition_code(kPathGen, 1), g, false);
        x[2] = code(condition_code(kPathGen, 2), s.N, false);
        const int zo = L_LAT + 1;
        [[unroll]] for (int l = 0; l < kW - 3; ++l)
            if (l < P_LAT) x[3 + l] = z[zo + l];
        [[unroll]] for (int o = 0; o < 3; ++o) eps[o] = z[zo + P_LAT + o];
        decoder_sample(kP0, kP1, kP2, P_IN, P_H1, P_H2, 3, x, eps, u);
        s.cos_theta = clamp(finite_value(code(output_code(kPathGen, 0), u[0], true)), -1.0, 1.0);
        float a = finite_value(code(output_code(kPathGen, 1), u[1], true));
        float b = finite_value(code(output_code(kPathGen, 2), u[2], true));
        project_into_disc(a, b);  // shared/sphere_step.h
        s.alpha = a;
        s.beta = b;
        if (!tilted) break;
        if (rng_uniform(rng) < tilt_acceptance(s.cos_theta, s.alpha, s.beta, ta, tb) ||
            draw == kTiltMaxDraws)
            break;
        draw_normals(rng, L_LAT + 1 + P_LAT + 3, z);
    }
    if (!with_event) return s;

    // EventGen(sigma, g, phi, N, cos_theta, alpha, beta) -> X into the unit ball, W unit
    draw_normals(rng, E_LAT + 6, ze);
    [[unroll]] for (int i = 0; i < kW; ++i) x[i] = 0.0;
    float cond[7] = float[7](sigma, g, phi, s.N, s.cos_theta, s.alpha, s.beta);
    [[unroll]] for (int i = 0; i < 7; ++i)
        x[i] = code(condition_code(kEventGen, i), cond[i], false);
    [[unroll]] for (int l = 0; l < kW - 7; ++l)
        if (l < E_LAT) x[7 + l] = ze[l];
    [[unroll]] for (int o = 0; o < 6; ++o) eps[o] = ze[E_LAT + o];
    decoder_sample(kE0, kE1, kE2, E_IN, E_H1, E_H2, 6, x, eps, u);
    float v[6];
    [[unroll]] for (int o = 0; o < 6; ++o)
        v[o] = finite_value(code(output_code(kEventGen, o), u[o], true));
    s.X = project_into_ball(vec3(v[0], v[1], v[2]));  // shared/sphere_step.h
    s.W = unit_or_z(vec3(v[3], v[4], v[5]));
    // The first event (the centre) is the representative one with the exact probability
    // (1 - phi) / (1 - phi^N) (1/N for phi = 1); EventGen models only events k >= 2.
    if (rng_uniform(rng) < first_event_probability(phi, s.N)) {
        s.X = vec3(0.0);
        s.W = vec3(0.0, 0.0, 1.0);
    }
    return s;
}

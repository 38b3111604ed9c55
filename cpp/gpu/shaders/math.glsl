// The scattering maths of cpp/core/frame.h and cpp/shared/ (HG, Fresnel, free flights,
// roulette, the sphere step's frame and exit), in GLSL. Each function mirrors the C++
// one of the same name; the GPU tests compare the two (tests/test_gpu.py).

const float kPi = 3.14159265358979323846;
const float kInvFourPi = 0.07957747154594767;
const float kHgIsotropicG = 1e-3;
const float kMinRouletteQ = 1e-20;
const float kInf = 1.0 / 0.0;

struct Frame {
    vec3 s, t, n;
};

// Any orthonormal completion of unit n (Duff et al. 2017), as Frame::from_z.
Frame frame_from_z(vec3 n) {
    float sign = (floatBitsToUint(n.z) >> 31) != 0u ? -1.0 : 1.0;  // copysign(1, n.z)
    float a = -1.0 / (sign + n.z);
    float b = n.x * n.y * a;
    Frame f;
    f.s = vec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f.t = vec3(b, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}

vec3 frame_to_world(Frame f, vec3 v) { return f.s * v.x + f.t * v.y + f.n * v.z; }

float hg_eval(float cos_theta, float g) {
    float denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return kInvFourPi * (1.0 - g * g) / (denom * sqrt(denom));
}

float hg_sample_cos(float u, float g) {
    if (abs(g) < kHgIsotropicG) return 1.0 - 2.0 * u;
    float sq = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    float c = (1.0 + g * g - sq * sq) / (2.0 * g);
    return clamp(c, -1.0, 1.0);
}

vec3 hg_sample(vec3 wi, float g, float u1, float u2) {
    float c = hg_sample_cos(u1, g);
    float s = sqrt(max(0.0, 1.0 - c * c));
    float phi = 2.0 * kPi * u2;
    return frame_to_world(frame_from_z(wi), vec3(s * cos(phi), s * sin(phi), c));
}

vec3 sample_uniform_sphere(float u1, float u2) {
    float z = 1.0 - 2.0 * u1;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * kPi * u2;
    return vec3(r * cos(phi), r * sin(phi), z);
}

float power_heuristic(float pdf_a, float pdf_b) {
    float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

// -ln(1 - u) / sigma_t (log1p(-u) in C++; u < 1 keeps it finite).
float sample_exponential(float u, float sigma_t) { return -log(1.0 - u) / sigma_t; }

float roulette_weight(float q, float u) {
    if (q >= 1.0) return 1.0;
    return q >= kMinRouletteQ && u < q ? 1.0 / q : 0.0;
}

// As fresnel_dielectric in cpp/shared/fresnel.h (eta = n_transmitted / n_incident).
float fresnel_dielectric(float cos_i, float eta, out float cos_t) {
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) {
        cos_t = 0.0;
        return 1.0;
    }
    float ct = sqrt(1.0 - sin2_t);
    float r_par = (eta * cos_i - ct) / (eta * cos_i + ct);
    float r_perp = (cos_i - eta * ct) / (cos_i + eta * ct);
    cos_t = ct;
    return 0.5 * (r_par * r_par + r_perp * r_perp);
}

// PyTorch's Softplus (threshold 20).
float softplus(float x) { return x > 20.0 ? x : log(1.0 + exp(x)); }

vec3 sphere_exit_point(float cos_theta) {
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    return vec3(sin_theta, 0.0, cos_theta);
}

vec3 sphere_exit_direction(float cos_theta, float alpha, float beta) {
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    float gamma = sqrt(max(0.0, 1.0 - alpha * alpha - beta * beta));
    return vec3(beta * cos_theta + gamma * sin_theta, alpha,
                gamma * cos_theta - beta * sin_theta);
}

Frame sphere_step_frame(vec3 w_in, float u) {
    Frame f = frame_from_z(w_in);
    float psi = 2.0 * kPi * u;
    float c = cos(psi), s = sin(psi);
    Frame r;
    r.s = f.s * c + f.t * s;
    r.t = f.t * c - f.s * s;
    r.n = f.n;
    return r;
}

// log(1 + x) and exp(x) - 1, accurate for small |x| too (GLSL has neither): the albedos
// near 1 of dense media make log(phi) a difference of nearly equal numbers, which a
// GPU's log (absolute error ~2^-21) would get wrong by 1 %. x = phi - 1 is exact.
float log1p_small(float x) {
    return abs(x) < 1e-2 ? x * (1.0 - x * (0.5 - x * (1.0 / 3.0 - 0.25 * x))) : log(1.0 + x);
}
float expm1_small(float x) {
    return abs(x) < 1e-2 ? x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0))) : exp(x) - 1.0;
}

// phi^N, the survival of a walk of N events.
float survival_power(float phi, float n) {
    if (phi >= 1.0) return 1.0;
    if (phi <= 0.0) return 0.0;
    return exp(n * log1p_small(phi - 1.0));
}

// Lambda = sum_{j=1..N} phi^j = phi (1 - phi^N) / (1 - phi) (N at phi = 1): the weight of
// a sphere step's one light connection from its representative event.
float event_weight_sum(float phi, float n) {
    if (phi >= 1.0) return n;
    if (phi <= 0.0) return 0.0;
    return phi * -expm1_small(n * log1p_small(phi - 1.0)) / (1.0 - phi);
}

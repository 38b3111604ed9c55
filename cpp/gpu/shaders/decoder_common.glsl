// What the GPU's decoders share: the sphere step's (model.glsl) and the cut sphere step's
// (cut_model.glsl). Both read decoders packed as gpu_scene_bake.h's pack_gpu_model lays
// them out: per decoder a header of kDecoderHeader floats (layers, input width, latent
// dimension, conditions, outputs; at 8 + 4 l layer l's inputs, outputs, softplus and
// where its weights start, its bias after them; at 32 + 8 i condition i's encoding, at 32
// + 8 (7 + o) output o's), the layers after the headers. Needs math.glsl and
// GL_EXT_control_flow_attributes.
#ifndef SSS_GPU_DECODER_COMMON_GLSL
#define SSS_GPU_DECODER_COMMON_GLSL

const int kDecoderHeader = 160;  // floats per decoder header
const float kMaxScatterCount = 1099511627776.0;  // 2^40, as in scattering_model.h

// e(x) (decode false) or its inverse for the encoding (kind, a, b, s, c, lo, hi, eps)
// (nn/decoder.h's Encoding).
float code_value(float kind_f, float a, float b, float s, float c, float lo, float hi,
                 float eps, float x, bool decode) {
    int kind = int(kind_f);
    if (kind == 0) return decode ? (x - b) / a : a * x + b;
    if (kind == 1) return decode ? (exp((x - b) / a) - c) / s : a * log(s * x + c) + b;
    return decode ? lo - eps + (hi - lo + 2.0 * eps) / (1.0 + exp(-(x - b) / a))
                  : a * log((x - lo + eps) / (hi - x + eps)) + b;
}

// n <= 16 standard normals by Box-Muller, drawn in the blocks of draw_normal_uniforms /
// assemble_normals (simd_decoder.cpp): block b takes the radii's uniforms of its k pairs,
// then the angles', and holds its k cosines, then its k sines.
void draw_normals(inout RngState rng, int n, out float z[16]) {
    const int pairs = (n + 1) / 2, blocks = (pairs + 3) / 4;
    [[unroll]] for (int i = 0; i < 16; ++i) z[i] = 0.0;
    [[unroll]] for (int blk = 0; blk < 2; ++blk) {
        if (blk < blocks) {
            int k = min(4, pairs - 4 * blk);
            float xr[4], xa[4];
            [[unroll]] for (int j = 0; j < 4; ++j) xr[j] = j < k ? rng_uniform(rng) : 0.0;
            [[unroll]] for (int j = 0; j < 4; ++j) xa[j] = j < k ? rng_uniform(rng) : 0.0;
            [[unroll]] for (int j = 0; j < 4; ++j) {
                float r = sqrt(-2.0 * log(1.0 - xr[j]));
                float ang = 2.0 * kPi * xa[j];
                if (j < k) {
                    z[8 * blk + j] = r * cos(ang);
                    z[8 * blk + k + j] = r * sin(ang);
                }
            }
        }
    }
}

// x made finite: NaN -> 0, infinities -> the largest floats.
float finite_value(float x) { return isnan(x) ? 0.0 : clamp(x, -kFloatMax, kFloatMax); }

// x, or `fallback` where x is NaN or infinite.
float finite_or(float x, float fallback) { return isnan(x) || isinf(x) ? fallback : x; }

#endif  // SSS_GPU_DECODER_COMMON_GLSL

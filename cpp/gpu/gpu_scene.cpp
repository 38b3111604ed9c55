#include "gpu/gpu_scene.h"

#include <cstring>
#include <fstream>

#include "core/check.h"
#include "core/files.h"

namespace sss {

namespace {

constexpr char kMagic[8] = {'S', 'S', 'S', 'G', 'P', 'U', '0', '8'};

template <class T>
void write_array(std::ofstream& out, const std::vector<T>& v) {
    const uint64_t n = v.size();
    out.write(reinterpret_cast<const char*>(&n), sizeof(n));
    out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(n * sizeof(T)));
}

template <class T>
void read_array(std::ifstream& in, std::vector<T>& v, const std::string& path,
                const char* what) {
    uint64_t n = 0;
    in.read(reinterpret_cast<char*>(&n), sizeof(n));
    if (!in || n > (uint64_t(1) << 34) / sizeof(T))
        fail(path, ": the ", what, " array is truncated or too large");
    v.resize(size_t(n));
    in.read(reinterpret_cast<char*>(v.data()), std::streamsize(n * sizeof(T)));
    if (!in) fail(path, ": the ", what, " array is truncated");
}

// The shapes of the `count` packed decoders in `packed` (decoder_common.glsl's layout),
// four per decoder: input width, the two hidden widths, latent dimension; checks that
// each layer's weights are where the packing put them, one after the other, which
// model.glsl computes from these shapes.
std::vector<int32_t> decoder_shapes(const std::vector<float>& packed, int count) {
    SSS_CHECK(packed.size() >= size_t(count * kGpuDecoderHeader));
    std::vector<int32_t> c;
    int32_t at = count * kGpuDecoderHeader;
    for (int d = 0; d < count; ++d) {
        const float* h = packed.data() + d * kGpuDecoderHeader;
        c.insert(c.end(), {int32_t(h[1]), int32_t(h[9]), int32_t(h[13]), int32_t(h[2])});
        for (int l = 0; l < kGpuLayers; ++l) {
            SSS_CHECK(int32_t(h[11 + 4 * l]) == at);
            at += int32_t(h[8 + 4 * l] * h[9 + 4 * l] + h[9 + 4 * l]);
        }
    }
    return c;
}

}  // namespace

std::vector<int32_t> gpu_model_constants(const std::vector<float>& model) {
    if (model.empty()) return {4, 8, 8, 2, 8, 16, 16, 5, 12, 16, 16, 5};
    return decoder_shapes(model, 3);
}

std::vector<int32_t> gpu_cut_model_constants(const std::vector<float>& cut_model) {
    if (cut_model.empty()) return {4, 8, 8, 2, 5, 8, 8, 4};
    return decoder_shapes(cut_model, 2);
}

void save_gpu_scene(const GpuSceneData& scene, const std::string& path) {
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path, ": cannot be written");
    out.write(kMagic, sizeof(kMagic));
    const uint64_t n = scene.source.size();
    out.write(reinterpret_cast<const char*>(&n), sizeof(n));
    out.write(scene.source.data(), std::streamsize(n));
    out.write(reinterpret_cast<const char*>(&scene.header), sizeof(scene.header));
    write_array(out, scene.nodes);
    write_array(out, scene.triangles);
    write_array(out, scene.floats);
    write_array(out, scene.model);
    write_array(out, scene.cut_model);
    if (!out) fail(path, ": writing failed");
}

GpuSceneData load_gpu_scene(const std::string& path) {
    check_input_file(path, "baked scene file");
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path, ": cannot be read");
    char magic[8] = {};
    in.read(magic, sizeof(magic));
    if (in && (std::memcmp(magic, "SSSGPU01", sizeof(magic)) == 0 ||
               std::memcmp(magic, "SSSGPU02", sizeof(magic)) == 0 ||
               std::memcmp(magic, "SSSGPU03", sizeof(magic)) == 0 ||
               std::memcmp(magic, "SSSGPU04", sizeof(magic)) == 0 ||
               std::memcmp(magic, "SSSGPU05", sizeof(magic)) == 0 ||
               std::memcmp(magic, "SSSGPU06", sizeof(magic)) == 0 ||
               std::memcmp(magic, "SSSGPU07", sizeof(magic)) == 0))
        fail(path, ": baked by an earlier version of sssphere (", std::string(magic, 8),
             ", an earlier layout of the scene): bake the scene again");
    if (!in || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0)
        fail(path, ": not a baked GPU scene (no SSSGPU08 header)");
    GpuSceneData s;
    uint64_t n = 0;
    in.read(reinterpret_cast<char*>(&n), sizeof(n));
    if (!in || n > 4096) fail(path, ": the source name is truncated");
    s.source.resize(size_t(n));
    in.read(s.source.data(), std::streamsize(n));
    in.read(reinterpret_cast<char*>(&s.header), sizeof(s.header));
    if (!in) fail(path, ": the header is truncated");
    read_array(in, s.nodes, path, "BVH node");
    read_array(in, s.triangles, path, "triangle");
    read_array(in, s.floats, path, "grid");
    read_array(in, s.model, path, "model");
    read_array(in, s.cut_model, path, "cut model");
    if (s.nodes.empty() || s.triangles.empty())
        fail(path, ": the scene has no triangles");
    return s;
}

}  // namespace sss

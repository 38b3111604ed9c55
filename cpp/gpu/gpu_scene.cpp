#include "gpu/gpu_scene.h"

#include <cstring>
#include <fstream>

#include "core/check.h"
#include "core/files.h"

namespace sss {

namespace {

constexpr char kMagic[8] = {'S', 'S', 'S', 'G', 'P', 'U', '0', '4'};

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

}  // namespace

std::vector<int32_t> gpu_model_constants(const std::vector<float>& model) {
    if (model.empty()) return {4, 8, 8, 2, 8, 16, 16, 5, 12, 16, 16, 5};
    SSS_CHECK(model.size() >= size_t(3 * kGpuDecoderHeader));
    std::vector<int32_t> c;
    // model.glsl computes where each layer's weights start from these shapes: they must
    // be where pack_gpu_model put them.
    int32_t at = 3 * kGpuDecoderHeader;
    for (int d = 0; d < 3; ++d) {
        const float* h = model.data() + d * kGpuDecoderHeader;
        c.push_back(int32_t(h[1]));   // input width
        c.push_back(int32_t(h[9]));   // layer 0's outputs
        c.push_back(int32_t(h[13]));  // layer 1's outputs
        c.push_back(int32_t(h[2]));   // latent dimension
        for (int l = 0; l < kGpuLayers; ++l) {
            SSS_CHECK(int32_t(h[11 + 4 * l]) == at);
            at += int32_t(h[8 + 4 * l] * h[9 + 4 * l] + h[9 + 4 * l]);
        }
    }
    return c;
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
               std::memcmp(magic, "SSSGPU03", sizeof(magic)) == 0))
        fail(path, ": baked by an earlier version of sssphere (", std::string(magic, 8),
             ", another layout of the scene header): bake the scene again");
    if (!in || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0)
        fail(path, ": not a baked GPU scene (no SSSGPU04 header)");
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
    if (s.nodes.empty() || s.triangles.empty())
        fail(path, ": the scene has no triangles");
    return s;
}

}  // namespace sss

#include "gpu/gpu_scene_bake.h"

#include <cmath>
#include <cstring>
#include <initializer_list>

#include "core/check.h"
#include "geometry/cut_planes.h"
#include "nn/cut_step_model.h"
#include "nn/scattering_model.h"
#include "render/sphere_tracing.h"

namespace sss {

namespace {

void put3(float* dst, Vec3 v, float w) {
    dst[0] = v.x, dst[1] = v.y, dst[2] = v.z, dst[3] = w;
}

}  // namespace

namespace {

// Decoders in the layout of gpu_scene.h ("Packed decoders"): their headers, then their
// layers; each of kGpuLayers layers of at most max_width units.
std::vector<float> pack_decoders(std::initializer_list<const Decoder*> decoders,
                                 int max_width) {
    std::vector<float> out(decoders.size() * kGpuDecoderHeader, 0.f);
    auto put_encoding = [&](size_t at, const Encoding& e) {
        out[at] = float(int(e.kind));
        out[at + 1] = e.a, out[at + 2] = e.b, out[at + 3] = e.s, out[at + 4] = e.c;
        out[at + 5] = e.lo, out[at + 6] = e.hi, out[at + 7] = e.eps;
    };
    size_t h = 0;
    for (const Decoder* dp : decoders) {
        const Decoder& d = *dp;
        if (int(d.layers.size()) != kGpuLayers || d.num_conditions() > 7 ||
            d.num_outputs() > 6 || d.input_width > max_width)
            fail(d.source, ": ", d.name, " has ", d.layers.size(),
                 " layers and input width ", d.input_width, "; the GPU path supports ",
                 kGpuLayers, " layers (two hidden, paper Table 1) of at most ", max_width,
                 " units");
        out[h] = float(d.layers.size());
        out[h + 1] = float(d.input_width);
        out[h + 2] = float(d.latent_dim);
        out[h + 3] = float(d.num_conditions());
        out[h + 4] = float(d.num_outputs());
        for (size_t l = 0; l < d.layers.size(); ++l) {
            const DenseLayer& L = d.layers[l];
            if (L.in > max_width || L.out > max_width)
                fail(d.source, ": ", d.name, " layer ", l, " (", L.in, " -> ", L.out,
                     ") is wider than the GPU path supports (", max_width, ")");
            out[h + 8 + 4 * l] = float(L.in);
            out[h + 9 + 4 * l] = float(L.out);
            out[h + 10 + 4 * l] = L.softplus ? 1.f : 0.f;
            out[h + 11 + 4 * l] = float(out.size());
            out.insert(out.end(), L.weight.begin(), L.weight.end());
            out.insert(out.end(), L.bias.begin(), L.bias.end());
        }
        for (int i = 0; i < d.num_conditions(); ++i)
            put_encoding(h + 32 + 8 * size_t(i), d.conditions[i].encoding);
        for (int o = 0; o < d.num_outputs(); ++o)
            put_encoding(h + 32 + 8 * size_t(7 + o), d.outputs[o].encoding);
        h += kGpuDecoderHeader;
    }
    return out;
}

}  // namespace

std::vector<float> pack_gpu_model(const ScatteringModel& m) {
    std::vector<float> out =
        pack_decoders({&m.length_gen(), &m.path_gen(), &m.event_gen()}, kGpuMaxWidth);
    // The step's normals live in 12 registers, EventGen's in 16 (model.glsl).
    if (m.length_gen().latent_dim + 1 + m.path_gen().latent_dim + 3 > 12)
        fail(m.where(), ": LengthGen and PathGen need more than the 12 normals per step ",
             "the GPU path supports");
    if (m.event_gen().latent_dim + 6 > 16)
        fail(m.where(),
             ": EventGen needs more than the 16 normals per step the GPU path ",
             "supports");
    // The tilt (model.glsl, tilt_at): where it starts and its nodes' counts in PathGen's
    // header, then the nodes (ln sigma, g) and the tables a and b.
    const StepTilt& t = m.tilt();
    if (!t.empty()) {
        const size_t h = size_t(kGpuDecoderHeader);
        out[h + 5] = float(out.size());
        out[h + 6] = float(t.log_sigma.size());
        out[h + 7] = float(t.g.size());
        for (const auto* v : {&t.log_sigma, &t.g, &t.a, &t.b})
            out.insert(out.end(), v->begin(), v->end());
    }
    if (out.size() > size_t(kGpuModelFloats))
        fail(m.where(), ": the decoders", t.empty() ? "" : " and the tilt", " take ",
             out.size(), " floats; the GPU path holds at most ", kGpuModelFloats);
    return out;
}

std::vector<float> pack_gpu_cut_model(const CutStepModel& m) {
    std::vector<float> out =
        pack_decoders({&m.length_gen(), &m.path_gen()}, kGpuCutMaxWidth);
    // cut_model.glsl draws a step's normals in one set of at most 16 (CutStepModel
    // checked the outputs: one of CutLengthGen, four of CutPathGen).
    if (m.length_gen().latent_dim + 1 + m.path_gen().latent_dim + 4 > 16)
        fail(m.where(),
             ": CutLengthGen and CutPathGen need more than the 16 normals per ",
             "step the GPU path supports");
    if (out.size() > size_t(kGpuCutModelFloats))
        fail(m.where(), ": the cut decoders take ", out.size(),
             " floats; the GPU path holds at most ", kGpuCutModelFloats);
    return out;
}

namespace {

// The cut decoders and every cut-taking shape's certificates (SphereTracing's), appended
// to the floats: the cells' entry indices as int32 bits, then 8 floats per entry.
// No shape taking cut steps (index-matched media, which sample lights at their events):
// no cut decoders, so the shaders are built without cut steps (CUTS = 0), which lavapipe
// compiles in half the time (28 s against 61 s, cold, on 2 cores).
void bake_cut_planes(const Scene& scene, const SphereTracing& st, GpuSceneData& out) {
    bool any = false;
    for (int i = 0; i < scene.num_shapes(); ++i) any = any || st.cuts(i);
    if (!any) return;
    GpuSceneHeader& h = out.header;
    out.cut_model = pack_gpu_cut_model(*st.cut_model());
    h.cut_params[0] = st.cut_sigma_hi();
    h.cut_params[1] = kCutMinDepth;
    for (int i = 0; i < scene.num_shapes(); ++i) {
        if (!st.cuts(i)) continue;
        const CutPlanes& c = st.cut_planes(i);
        GpuCutGrid& g = h.cut_grids[i];
        put3(g.origin, c.origin(), c.cell_size());
        put3(g.params, Vec3(c.radius(), c.guard(), st.cut_sigma_min(i)),
             c.cell_size() > 0.f ? 1.f / c.cell_size() : 0.f);
        for (int a = 0; a < 3; ++a) g.n[a] = c.cells_along(a);
        g.n[3] = int32_t(out.floats.size());
        for (int32_t e : c.index()) {
            float bits;
            std::memcpy(&bits, &e, sizeof(bits));
            out.floats.push_back(bits);
        }
        g.entries[0] = int32_t(out.floats.size());
        for (const CutPlanes::Entry& e : c.entries())
            out.floats.insert(out.floats.end(), {e.centre.x, e.centre.y, e.centre.z, e.m,
                                                 e.n.x, e.n.y, e.n.z, 0.f});
        if (out.floats.size() >= (size_t(1) << 31))
            fail(out.source, ": the cut planes are too large for the GPU path");
    }
}

}  // namespace

GpuSceneData bake_gpu_scene(const Scene& scene, const std::string& integrator, bool nee,
                            float sphere_threshold, const std::string& models,
                            const std::string& cut_models) {
    const SceneDesc& desc = scene.desc();
    if (integrator != "pt" && integrator != "st")
        fail("integrator '", integrator, "' is not allowed (allowed: 'pt', 'st')");
    if (scene.num_shapes() > kGpuMaxShapes)
        fail(desc.source, ": ", scene.num_shapes(),
             " shapes; the GPU path renders at most ", kGpuMaxShapes,
             " (allowed with backend 'vulkan': 1 to ", kGpuMaxShapes,
             " shapes; backend 'cpu' takes any number)");
    GpuSceneData out;
    out.source = desc.source;
    GpuSceneHeader& h = out.header;

    // Camera, as PinholeCamera.
    const Camera& c = desc.camera;
    const Vec3 forward = unit_normal(c.target - c.origin);
    const Vec3 right = unit_normal(cross(forward, c.up));
    const Vec3 up = cross(right, forward);
    put3(h.cam_origin, c.origin, std::tan(0.5f * c.fov * 0.017453292519943295f));
    put3(h.cam_forward, forward, float(c.width) / float(c.height));
    put3(h.cam_right, right, scene.camera_ray_start());
    put3(h.cam_up, up, 0.f);

    // Lights, for NEE in the shaders; area lights are also the meshes after the shapes
    // (Scene's order), hit by paths, and the environment a constant seen by escaping
    // ones.
    if (desc.lights.size() > size_t(kGpuMaxLights))
        fail(desc.source, ": ", desc.lights.size(),
             " lights; the GPU path renders at most ", kGpuMaxLights,
             " (allowed with backend 'vulkan': up to ", kGpuMaxLights,
             " lights, an environment counting as one; backend 'cpu' takes any number)");
    // The point and directional lights first: a regularized smooth dielectric's vertices
    // sample only those, and a step's clearance looks only at those.
    std::vector<size_t> order;
    for (int delta = 1; delta >= 0; --delta)
        for (size_t i = 0; i < desc.lights.size(); ++i)
            if (desc.lights[i].is_delta() == bool(delta)) order.push_back(i);
    uint32_t num_delta = 0;
    int emitters = 0;
    for (size_t i = 0; i < order.size(); ++i) {
        const Light& l = desc.lights[order[i]];
        GpuLight& gl = h.lights[i];
        put3(gl.a, l.a, float(l.type));
        put3(gl.b, l.b, l.scalar);
        put3(gl.c, l.c, 0.f);
        put3(gl.value, l.value * scene.light_scale(int(order[i])),
             float(scene.light_medium(int(order[i]))));
        if (l.kind().quad) put3(h.emitters[emitters++], l.value, float(i));
        if (l.kind().environment) put3(h.environment, Vec3(float(i), 0.f, 0.f), 1.f);
        num_delta += l.is_delta() ? 1u : 0u;
    }

    // Shapes and their grids.
    std::vector<const TriangleMesh*> meshes;
    bool shadow_rays_pass = false;  // some vertex can see a light straight
    for (int i = 0; i < scene.num_shapes(); ++i) {
        const Shape& s = desc.shapes[i];
        meshes.push_back(&s.mesh);
        // (a regularized smooth boundary samples the point and directional lights only)
        const bool boundary_samples = s.boundary.samples_delta_lights_only()
                                          ? num_delta > 0
                                          : s.boundary.samples_lights();
        shadow_rays_pass = shadow_rays_pass || s.is_surface() ||
                           s.boundary.passes_shadow_rays() || boundary_samples;
        put3(h.shapes[i].surface,
             Vec3(float(s.surface.type), s.surface.x,
                  !s.is_surface() && scene.medium_samples_lights(int(i)) ? 1.f : 0.f),
             0.f);
        put3(h.shapes[i].surface_color, s.surface.color, 0.f);
        put3(h.shapes[i].sigma_t, s.medium.sigma_t, 0.f);
        put3(h.shapes[i].phase,
             Vec3(float(s.medium.phase.type), s.medium.phase.x, s.medium.phase.y), 0.f);
        put3(h.shapes[i].albedo, s.medium.albedo,
             s.is_surface() || !scene.touches_surfaces(i) ? 0.f : 1.f);
        put3(h.shapes[i].boundary,
             Vec3(float(s.boundary.type), s.boundary.x, s.boundary.y), s.boundary.z);
        const DistanceGrid& g = scene.grid(i);
        GpuGrid& gg = h.grids[i];
        put3(gg.origin, g.origin(), g.cell_size());
        gg.scale[0] = g.cell_size() > 0.f ? 1.f / g.cell_size() : 0.f;
        gg.scale[1] = g.guard();
        gg.n[0] = g.nx(), gg.n[1] = g.ny(), gg.n[2] = g.nz();
        gg.n[3] = int32_t(out.floats.size());
        const auto& v = g.node_distances();
        out.floats.insert(out.floats.end(), v.begin(), v.end());
        if (out.floats.size() >= (size_t(1) << 31))
            fail(desc.source, ": the distance grids are too large for the GPU path");
    }
    // The lights' table of floats after the grids.
    h.lighting[3] = uint32_t(out.floats.size());
    out.floats.insert(out.floats.end(), desc.light_floats.begin(),
                      desc.light_floats.end());
    if (out.floats.size() >= (size_t(1) << 31))
        fail(desc.source,
             ": the distance grids and light tables are too large for the GPU "
             "path");
    h.counts[0] = uint32_t(scene.num_shapes());
    h.counts[1] = uint32_t(emitters);
    h.counts[2] = uint32_t(c.width);
    h.counts[3] = uint32_t(c.height);
    h.lighting[0] = uint32_t(desc.lights.size());
    // A straight shadow ray never leaves a smooth dielectric boundary (docs/notation.md,
    // "Next-event estimation"): with only those and no opaque surface, NEE finds nothing
    // and the shaders skip it (the same estimator).
    h.lighting[1] = nee && shadow_rays_pass && !desc.lights.empty() ? 1u : 0u;
    h.lighting[2] = num_delta;
    // The area lights' quads, after the shapes in Scene's order (its ray tracer's).
    std::vector<TriangleMesh> quads;
    for (const Light& l : desc.lights)
        if (l.kind().quad) quads.push_back(l.quad_mesh());
    for (const TriangleMesh& q : quads) meshes.push_back(&q);
    FlatBvh bvh = build_flat_bvh(meshes);
    out.nodes = std::move(bvh.nodes);
    out.triangles = std::move(bvh.triangles);
    for (FlatTriangle& t : out.triangles)
        if (int(t.mesh) < scene.num_shapes() &&
            scene.touches_surface(int(t.mesh), t.prim))
            t.touching = 1.f;

    h.params[0] = 0.f;  // unused (rays are offset by error bounds: shared/ray_offset.h)
    h.params[1] = INFINITY;  // no sphere steps ("pt")
    h.params[2] = kWalkSigmaMax;
    h.params[3] = scene.grey_media() ? 1.f : 0.f;
    if (!cut_models.empty() && integrator != "st")
        fail("cut_models is an option of integrator 'st' (the integrator is '",
             integrator, "')");
    if (integrator == "st") {
        // The same checks as the CPU's "st" (ranges of the models against the media),
        // and its clearances.
        SphereTracing st(scene, sphere_threshold, SphereSampler::Model, models, nee,
                         StepNee::Hits, cut_models);
        h.params[1] = sphere_threshold;
        h.params[2] = st.sigma_max();
        for (int i = 0; i < scene.num_shapes(); ++i)
            h.shapes[i].sigma_t[3] = st.clearance(i);
        if (st.model()) out.model = pack_gpu_model(*st.model());  // loaded once
        out.warnings = st.warnings();
        if (st.cut_model()) bake_cut_planes(scene, st, out);
    }
    return out;
}

}  // namespace sss

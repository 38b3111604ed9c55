// Integrators "pt" and "st" on the GPU: the loop of PathTracer::run (cpp/render/pt.cpp).
// With the specialization constant NEE (the baked scene's lighting.y) every scattering
// event samples one light, as PathTracer::direct_light with MIS; a sphere step's exit
// flight counts the lights it hits with weight 1, and its ball keeps clear of the
// boundary and the point lights where point or directional lights would need its events
// to sample them (StepNee::Hits, SphereTracing::clearance). Without it emitters
// count only when a path hits them (nee = false), which in a scene whose media all have
// dielectric boundaries is also what NEE computes (a straight shadow ray never leaves such
// a medium). The includer defines SSS_ST (0 or 1).
//
// A dispatch renders paths 0 .. num_paths-1, path i being sample sample0 + i / (W H) of
// pixel i % (W H) (row-major), on L lanes (invocations): lane l takes paths l, l + L,
// l + 2L, ... one after the other. With L < num_paths a lane whose path ends starts its
// next one while the other lanes of its subgroup go on, so a long path holds up its own
// lane rather than its subgroup (path regeneration). The paths are dealt out in this fixed
// order, not from an atomic counter: Mesa 22's lavapipe lost paths that way. Sample k of
// pixel (x, y) uses rng_make(seed, y * width + x, k), as on the CPU, so L changes no result.

#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_ballot : require

layout(local_size_x = 64) in;

#include "gpu/shaders/scene_buffers.glsl"  // before math.glsl: the lights read its floats
#include "gpu/shaders/math.glsl"
#include "gpu/shaders/scene.glsl"

const int kModelVec4 = 1024;  // kGpuModelFloats / 4
layout(std140, binding = 4) uniform Model { vec4 model_v[kModelVec4]; };
// Per path i: radiance (rgb), and the ordinary scattering events and sphere steps, the
// latter with bit kGpuWritten set (gpu/shaders/layout.h says why).
layout(std430, binding = 5) writeonly buffer OutRadiance { vec4 out_radiance[]; };
layout(std430, binding = 6) writeonly buffer OutCounts { uvec2 out_counts[]; };

layout(push_constant) uniform Push { SSS_GPU_RENDER_PUSH_FIELDS };

#include "gpu/shaders/model.glsl"

layout(constant_id = 12) const bool NEE = false;

// Cut sphere steps ("st" with cut_models): the packed cut decoders, their shapes
// (cut_model.glsl, constants 13-20), and whether the scene takes any (CUTS).
// A uniform block, as model.glsl's: read from a storage buffer, the cut decoders' weights
// made lavapipe (LLVM) take five minutes to build the render pipelines, cold; one now.
const int kCutVec4 = 1024;  // kGpuCutModelFloats / 4
layout(std140, binding = 7) uniform CutModel { vec4 cut_v[kCutVec4]; };
layout(constant_id = 21) const bool CUTS = false;
#if SSS_ST
#include "gpu/shaders/cut_model.glsl"
#endif

// The origin of a ray leaving the surface point of `hit` in direction w (PathTracer's
// leave(): shared/ray_offset.h).
vec3 leave(Hit hit, vec3 w) { return offset_ray_origin(hit.p, hit.p_error, hit.normal, w); }

bool is_black(vec3 v) { return v.x == 0.0 && v.y == 0.0 && v.z == 0.0; }

// A GpuShape's boundary unpacked (gpu/shaders/layout.h).
BoundaryData boundary_data(GpuShape s) {
    BoundaryData b;
    b.type = int(s.boundary.x);
    b.x = s.boundary.y;
    b.y = s.boundary.z;
    b.z = s.boundary.w;
    return b;
}

// A GpuShape's phase function unpacked (gpu/shaders/layout.h).
PhaseData phase_data(GpuShape s) {
    PhaseData p;
    p.type = int(s.phase.x);
    p.x = s.phase.y;
    p.y = s.phase.z;
    return p;
}

// A GpuShape's opaque surface unpacked (gpu/shaders/layout.h); type -1: a medium.
SurfaceData surface_data(GpuShape s) {
    SurfaceData d;
    d.type = int(s.surface.x);
    d.color = s.surface_color.xyz;
    d.x = s.surface.y;
    return d;
}

bool is_surface(uint mesh) { return mesh < counts.x && shapes[mesh].surface.x >= 0.0; }

// What else the ray from o along d meets where it hits `hit`, to rounding
// (PathTracer::other_at).
bool other_at(vec3 o, vec3 d, Hit hit, out Hit other) {
    return intersect_skipping(o, d, 0.0, tie_reach(o, d, hit.t, hit.p_error, hit.normal),
                              hit.mesh, other);
}

// A GpuLight unpacked (gpu/shaders/layout.h).
LightData light_data(GpuLight g) {
    LightData l;
    l.type = int(g.a.w);
    l.a = g.a.xyz;
    l.b = g.b.xyz;
    l.c = g.c.xyz;
    l.value = g.value.rgb;
    l.scalar = g.b.w;
    return l;
}

// PathTracer::transmittance from p along w over dist, starting in `shape` (-1: vacuum):
// Beer's law through the media it crosses at index-matched boundaries; 0 when a dielectric
// boundary, an opaque surface or an emitter is in the way, or after kMaxShadowCrossings
// searches. The CPU gathers every crossing of the ray at once, so a surface lying on a face
// is among them whichever rounding puts first; here each search starts past the last
// crossing, so a face marked touching is crossed only after a search around it (from the
// last crossing to tie_reach past it, passing through its mesh, as other_at) finds no
// surface there (a lamp under a floor lit an index-matched cube resting on it). One
// traversal per iteration, for lavapipe's loop budget (meet_boundary). light_in: the
// medium the light at dist lies inside (Scene::light_medium), -1 for none.
vec3 transmittance(vec3 p, vec3 w, float dist, int shape, int light_in) {
    vec3 tr = vec3(1.0);
    float t_prev = 0.0;
    bool around = false;  // the last search found `face`, marked touching: search around it
    Hit face;
    for (int i = 0; i < kMaxShadowCrossings; ++i) {
        Hit h;
        float reach = around ? min(dist, tie_reach(p, w, face.t, face.p_error, face.normal))
                             : dist;
        bool hit = intersect_skipping(p, w, t_prev, reach, around ? face.mesh : kNoMesh, h);
        if (around) {
            if (hit && is_surface(h.mesh) && h.t < kShadowRayEnd * dist) return vec3(0.0);
            around = false;
            h = face;
            hit = true;
        } else if (hit && h.touching) {
            around = true;
            face = h;
            continue;
        }
        if (shape >= 0) tr *= beer(shapes[shape].sigma_t.xyz, (hit ? h.t : dist) - t_prev);
        if (!hit || is_black(tr)) return tr;
        if (is_surface(h.mesh) && h.t >= kShadowRayEnd * dist) return tr;  // at the light
        if (int(h.mesh) == light_in && shape == light_in && h.t >= kShadowRayEnd * dist)
            return tr * beer(shapes[shape].sigma_t.xyz, dist - h.t);  // a light on its face
        if (h.mesh >= counts.x || is_surface(h.mesh) ||
            !boundary_passes_shadow_rays(boundary_data(shapes[h.mesh])))
            return vec3(0.0);
        shape = dot(w, h.normal) < 0.0 ? int(h.mesh) : -1;
        t_prev = h.t;
    }
    return vec3(0.0);
}

// The kinds of path vertex that sample lights (PathTracer's MediumScatter,
// SurfaceScatter and BoundaryScatter).
const int kMediumVertex = 0;
const int kSurfaceVertex = 1;
const int kBoundaryVertex = 2;
// A boundary vertex whose outside an opaque surface covers (the gap's face: Path::gap 2),
// which no light reaches from outside (PathTracer's BoundaryScatter::covered).
const int kCoveredBoundaryVertex = 3;
// sample_light's `march` for vertices off a medium: no second shadow-ray roulette.
const vec3 kNoMarch = vec3(0.0, 0.0, 1.0);

// PathTracer's shadow_march_keep: the probability to trace a shadow ray from a scattering
// event at p in `shape` along w to a light dist away, by sphere tracing it through the
// shape's grid from the bound r at p (march: r, the extinction sigma of the bounds, and
// the probability `kept` of the roulette on exp(-sigma r) before).
float shadow_march_keep(int shape, vec3 p, vec3 w, float dist, vec3 march) {
    float t = march.x;
    for (int i = 1; i < kShadowMarchQueries && t < dist && march.y * t < kShadowMarchDepth;
         ++i) {
        float step = grid_query(shape, p + w * t);
        if (!(step > 0.0)) break;
        t += step;
    }
    return shadow_keep_again(exp(-march.y * min(t, dist)), march.z);
}

// PathTracer::sample_light with MIS at a vertex at p, the photon arriving along d: a
// scattering event in medium `shape` with phase function ph (kMediumVertex), a point of
// an opaque surface sf found by `hit` (in medium `shape`, -1: vacuum; kSurfaceVertex), or
// a point of a rough boundary, the shape of `hit`'s (kBoundaryVertex, or
// kCoveredBoundaryVertex). One light chosen uniformly, weighted by the number of lights;
// with delta_only, one of the point and directional lights (the first lighting.z of
// lights[]). march: shadow_march_keep's for a medium vertex, kNoMarch for the others.
vec3 sample_light(vec3 p, vec3 d, int shape, PhaseData ph, int vertex, SurfaceData sf,
                  Hit hit, bool delta_only, vec3 march, inout RngState rng) {
    uint count = delta_only ? lighting.z : lighting.x;
    if (count == 0u) return vec3(0.0);
    float n_lights = float(count);
    uint i = min(count - 1u, uint(rng_uniform(rng) * n_lights));
    LightData l = light_data(lights[i]);
    float u1 = rng_uniform(rng), u2 = rng_uniform(rng);
    LightSample ls = light_sample(l, p, u1, u2);  // render/lights/registry.h
    vec3 f;  // the vertex's scattering towards ls.w, and the pdf of sampling it there
    float pdf;
    if (vertex == kSurfaceVertex) {
        SurfaceEval e = surface_eval(sf, -d, ls.w, hit.normal);
        f = e.f;
        pdf = e.pdf;
    } else if (vertex >= kBoundaryVertex) {
        BoundaryEval e =
            boundary_eval(boundary_data(shapes[hit.mesh]), d, ls.w, hit.normal, ls.pdf == 0.0);
        bool covered = vertex == kCoveredBoundaryVertex && dot(ls.w, hit.normal) >= 0.0;
        f = covered ? vec3(0.0) : vec3(e.f);
        pdf = covered ? 0.0 : e.pdf;
        shape = dot(ls.w, hit.normal) < 0.0 ? int(hit.mesh) : -1;
    } else {
        pdf = phase_eval(ph, dot(d, ls.w));
        f = vec3(pdf);
    }
    vec3 sum = vec3(0.0);
    // A second shadow-ray roulette, on the bound along the light's direction.
    float shadow_weight = 1.0;
    if (vertex == kMediumVertex && !is_black(ls.L) && !is_black(f)) {
        float keep = shadow_march_keep(shape, p, ls.w, ls.dist, march);
        if (keep < 1.0) shadow_weight = roulette_weight(keep, rng_uniform(rng));
    }
    if (shadow_weight > 0.0 && !is_black(ls.L) && !is_black(f)) {
        vec3 tr = shadow_weight * transmittance(vertex == kMediumVertex ? p : leave(hit, ls.w),
                                                ls.w, ls.dist, shape, int(lights[i].value.w));
        sum = ls.pdf == 0.0  // a delta light
                  ? ls.L * tr * f
                  : ls.L * tr * f * (power_heuristic(ls.pdf / n_lights, pdf) / ls.pdf);
    }
    return sum * n_lights;
}

// PathTracer::direct_light with MIS at a scattering event at p (grid bound r, < 0:
// unknown) in `shape`, the photon travelling along d: sample_light, after a shadow ray
// whose transmittance the bound puts below kShadowRoulette is kept with probability
// bound / kShadowRoulette and reweighted.
vec3 direct_light(vec3 p, float r, vec3 d, int shape, int channel, inout RngState rng) {
    GpuShape s = shapes[shape];
    if (s.surface.z == 0.0) return vec3(0.0);  // Scene::medium_samples_lights
    float sigma_min =
        channel < 0 ? min(s.sigma_t.x, min(s.sigma_t.y, s.sigma_t.z)) : s.sigma_t[channel];
    if (r < 0.0) r = grid_query(shape, p);
    // ... or as far as a point light inside the medium, if nearer (PathTracer::direct_light;
    // the delta lights come first in lights[], lighting.z of them).
    float reach = r;
    for (uint i = 0u; i < lighting.z; ++i)
        reach = min(reach, light_sample(light_data(lights[i]), p, 0.5, 0.5).dist);
    float kept = shadow_keep_probability(exp(-sigma_min * reach));
    float shadow_weight = 1.0;
    if (kept < 1.0) {
        shadow_weight = roulette_weight(kept, rng_uniform(rng));
        if (shadow_weight == 0.0) return vec3(0.0);
    }
    Hit none;
    return sample_light(p, d, shape, phase_data(s), kMediumVertex, surface_data(s), none,
                        false, vec3(r, sigma_min, kept), rng) *
           shadow_weight;
}

// One path's state between iterations of its loop.
struct Path {
    RngState rng;
    vec3 o, d, L, beta;
    float beta_start;
    int channel;    // the hero (pt) or carried (st) channel; -1: grey media
    // Spectral MIS ("pt" on chromatic media, PathState): each channel's pdf of the path
    // over the hero's; a vertex contributes beta / mean(ratio).
    bool spectral;
    vec3 ratio;
    int shape;      // the medium holding the photon; -1 = vacuum
    float r_at_o;   // the grid's bound at o when known, else < 0
    bool r_shrunk;  // r_at_o is a shrunk ball's radius, not the grid's bound
    // "st": the cell of the last grid query (grid_query_in_cell; -1: none) and the largest
    // bound the grid gives in it.
    int query_cell;
    float query_cell_bound;
    // NEE's MIS (PathState): whether the last vertex was specular (camera, dielectric
    // boundary, sphere step), else the phase pdf of the direction sampled at the last
    // scattering event and where that was.
    bool specular;
    float phase_pdf;
    vec3 scatter_pos;
    uint events, steps;
    bool done;
    bool pending;   // "st": waits for a sphere step at o, of bound r_step
    float r_step;   //   (a cut step: the certificate's plane distance s)
    bool cut;       //   a cut sphere step, its plane's normal cut_n
    vec3 cut_n;
    // A face of a dielectric medium met where an opaque surface lies on it, as across a
    // gap too thin to see (PathTracer::run's across_gap), one round per iteration: 1, the
    // path is in the gap and meets the surface gap_on next; 2, it crosses the face
    // gap_face next; 0, not in a gap.
    uint gap;
    Hit gap_face, gap_on;
};

// The throughput a vertex's light is weighted by, and the path's Russian roulette on it
// (PathTracer::run's weight and roulette).
vec3 path_weight(Path p) {
    return p.spectral ? p.beta * (3.0 / (p.ratio.x + p.ratio.y + p.ratio.z)) : p.beta;
}

bool path_survives_roulette(inout Path p) {
    float start = p.spectral ? p.beta_start * (p.ratio.x + p.ratio.y + p.ratio.z) / 3.0
                             : p.beta_start;
    return survives_roulette(p.beta, start, p.rng);
}

// An opaque surface at `hit` (PathTracer::run's reflect): light sampling, then a
// reflected direction; it counts as a scattering event.
void reflect_off(inout Path p, Hit hit) {
    if (max_bounces >= 0 && int(p.events) >= max_bounces) {  // ends without happening
        p.done = true;
        return;
    }
    ++p.events;
    SurfaceData sf = surface_data(shapes[hit.mesh]);
    if (NEE) {
        PhaseData none;
        p.L += path_weight(p) *
               sample_light(hit.p, p.d, p.shape, none, kSurfaceVertex, sf, hit, false,
                            kNoMarch, p.rng);
    }
    float u1 = rng_uniform(p.rng), u2 = rng_uniform(p.rng);
    SurfaceSample ss = surface_sample(sf, -p.d, hit.normal, u1, u2);
    p.beta *= ss.weight;
    if (!(ss.pdf > 0.0) || is_black(p.beta)) {
        p.done = true;
        return;
    }
    if (NEE) {  // for the MIS weight of a light this direction may hit
        p.phase_pdf = ss.pdf;
        p.scatter_pos = hit.p;
        p.specular = false;
    }
    p.d = ss.wo;
    p.o = leave(hit, p.d);
    p.r_at_o = -1.0;
    if (!path_survives_roulette(p)) p.done = true;
}

// The photon meets the boundary of the shape of `hit`, from outside or inside
// (PathTracer::run's cross): a rough interface's vertex samples lights first (a
// regularized smooth one's the point and directional lights); then the
// boundary reflects or transmits it.
void cross(inout Path p, Hit hit) {
    BoundaryData bd = boundary_data(shapes[hit.mesh]);
    int lights = boundary_light_sampling(bd);
    if (NEE && lights != kSamplesNoLights) {
        PhaseData none;
        SurfaceData no_surface;
        int vertex = p.gap == 2u ? kCoveredBoundaryVertex : kBoundaryVertex;
        p.L += path_weight(p) * sample_light(hit.p, p.d, p.shape, none, vertex, no_surface,
                                             hit, lights == kSamplesDeltaLights, kNoMarch,
                                             p.rng);
    }
    BoundaryEvent b = boundary_cross(bd, p.d, hit.normal, p.rng);
    p.beta *= b.weight;
    if (is_black(p.beta)) {
        p.done = true;
        return;
    }
    if (b.pdf > 0.0) {  // a sampled lobe: the next emitter hit shares MIS with it
        if (NEE) {
            p.phase_pdf = b.pdf;
            p.scatter_pos = hit.p;
            p.specular = false;
        }
    } else {
        p.specular = p.specular || b.specular;
    }
    p.d = b.d;
    p.o = leave(hit, p.d);
    if (b.crossed) p.shape = p.shape < 0 ? int(hit.mesh) : -1;
    p.r_at_o = p.shape >= 0 ? 0.0 : -1.0;
}

#if SSS_ST
// SphereTracing::step_radius: the grid's bound r at p, or the ball that keeps the shape's
// clearance (sigma_t.w mean free paths of sigma) from the boundary and the point lights
// (the delta lights at a finite distance, among the first lighting.z of lights[]).
float step_radius(GpuShape s, vec3 p, float r, float sigma) {
    float c = s.sigma_t.w;
    if (c == 0.0) return r;
    if (sigma * r < params.y + c) return -1.0;
    float light_dist = kInf;
    for (uint i = 0u; i < lighting.z; ++i)
        light_dist = min(light_dist, light_sample(light_data(lights[i]), p, 0.5, 0.5).dist);
    return cleared_step_radius(r, light_dist, c, sigma);
}

// Where the path goes on in one channel before a step (PathTracer::run's to_one_channel):
// with spectral MIS, a channel picked afresh, weight 3.
void to_one_channel(inout Path p) {
    if (!p.spectral) return;
    vec3 w = path_weight(p);
    p.channel = min(2, int(rng_uniform(p.rng) * 3.0));
    float wc = w[p.channel];
    p.beta = vec3(0.0);
    p.beta[p.channel] = 3.0 * wc;
    p.ratio = vec3(1.0);
    p.spectral = false;
    p.beta_start = 3.0;
}

// The cut step's certificate at x in `shape` (SphereTracing::cut_certificate, CutPlanes::
// query): false where x's cell has none or its plane is nearer than the least depth.
bool cut_certificate(int shape, vec3 x, out vec3 n, out float s) {
    GpuCutGrid g = cut_grids[shape];
    n = vec3(0.0, 0.0, 1.0);
    s = 0.0;
    if (g.n.x == 0) return false;
    vec3 q = (x - g.origin.xyz) * g.params.w;
    if (!(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0)) return false;
    int i = int(q.x), j = int(q.y), k = int(q.z);
    if (i >= g.n.x || j >= g.n.y || k >= g.n.z) return false;
    int e = floatBitsToInt(scene_floats[g.n.w + (k * g.n.y + j) * g.n.x + i]);
    if (e < 0) return false;
    int at = g.entries.x + 8 * e;
    vec3 centre = vec3(scene_floats[at], scene_floats[at + 1], scene_floats[at + 2]);
    n = vec3(scene_floats[at + 4], scene_floats[at + 5], scene_floats[at + 6]);
    s = scene_floats[at + 3] - dot(x - centre, n) - g.params.y;
    return s * g.params.z >= cut_params.y;
}
#endif

// The grid's bound at x in p's medium; "st" keeps the query's cell and its largest bound.
float path_grid_query(inout Path p, vec3 x) {
#if SSS_ST
    return grid_query_in_cell(p.shape, x, p.query_cell, p.query_cell_bound);
#else
    return grid_query(p.shape, x);
#endif
}

// One iteration of PathTracer::run's loop: a flight in vacuum to the next surface, or a
// free flight in a medium and what ends it (a collision or the boundary). A collision
// deep enough for a sphere step only marks the path as pending ("st").
// The boundary or surface `hit` that the path's ray reaches (from vacuum: a surface, or a
// shape's face from outside; from inside a medium: anything), or the gap's next round, as
// PathTracer::run. Where a surface and a face meet to rounding, the ray is traced once
// more (other_at) and the two are met as across a gap too thin to see, one round per
// iteration (Path::gap). Each of other_at, reflect_off and cross appears once, and this
// function is called once: lavapipe gives an invocation 65535 loop iterations in all, and
// code its lanes skip evidently uses them too (every copy of reflect_off or cross carries
// sample_light's shadow ray), so each inlined copy shortens the longest path it finishes.
void meet_boundary(inout Path p, Hit hit) {
    bool in_gap = p.gap != 0u;
    bool surface = is_surface(hit.mesh);
    bool dielectric = p.shape >= 0 && !boundary_passes_shadow_rays(boundary_data(shapes[p.shape]));
    // An unexpected face from inside passes straight through, into the shape whose front
    // face it crosses.
    if (!in_gap && p.shape >= 0 && !surface &&
        (int(hit.mesh) != p.shape || dot(p.d, hit.normal) <= 0.0)) {
        if (dot(p.d, hit.normal) < 0.0 && hit.mesh < counts.x) p.shape = int(hit.mesh);
        p.o = leave(hit, p.d);
        return;
    }
    // Whether something else may lie here: a surface on a face marked touching (entered
    // from outside or left from inside), or the face of the dielectric medium the path is
    // in, under a surface met from inside it (where some face of it touches a surface).
    bool probe = !in_gap && (surface ? dielectric && shapes[p.shape].albedo.w > 0.0
                                     : hit.touching);
    Hit other;
    bool found = probe && other_at(p.o, p.d, hit, other);
    Hit target = hit;
    bool reflect = surface;
    if (found && surface && other.mesh == uint(p.shape) && other.touching &&
        dot(p.d, other.normal) > 0.0) {
        p.gap = 2u;  // the face under the surface first
        p.gap_face = other;
        p.gap_on = hit;
        target = other;
        reflect = false;
    } else if (found && !surface && is_surface(other.mesh)) {
        if (dielectric) {  // leaving a dielectric: its face first
            p.gap = 2u;
            p.gap_face = hit;
            p.gap_on = other;
        } else {  // entering, or leaving an index-matched face: the surface
            target = other;
            reflect = true;
        }
    }
    if (reflect)
        reflect_off(p, target);
    else
        cross(p, target);
    // The gap's next round: out of the face into the gap, the surface; sent back from
    // the surface towards the face, the face.
    if (p.gap != 0u) {
        bool again = !p.done && (reflect ? dot(p.d, p.gap_face.normal) < 0.0 : p.shape < 0);
        p.gap = again ? (reflect ? 2u : 1u) : 0u;
    }
}


// One flight of the path (PathTracer::run's loop body): true when it ends on a boundary
// or surface `hit` for meet_boundary.
bool fly(inout Path p, out Hit hit) {
    uint num_shapes = counts.x;
    if (p.shape < 0) {
        // Vacuum: fly to the next surface.
        if (!intersect(p.o, p.d, kInf, hit)) {
            if (environment.w != 0.0) {
                LightEval e = light_eval(light_data(lights[int(environment.x)]),
                                         p.scatter_pos, p.d, kInf, vec3(0.0));
                float w = NEE && !p.specular
                              ? power_heuristic(p.phase_pdf, e.pdf / float(lighting.x))
                              : 1.0;
                p.L += path_weight(p) * e.L * w;
            }
            p.done = true;
            return false;
        }
        vec3 x = hit.p;
        if (hit.mesh >= num_shapes) {  // an emitter's quad: absorbs
            // NEE's pdf at the last scattering event, across index-matched boundaries.
            LightEval e = light_eval(light_data(lights[int(emitters[hit.mesh - num_shapes].w)]),
                                     p.scatter_pos, p.d, length(x - p.scatter_pos), hit.normal);
            float w = NEE && !p.specular ? power_heuristic(p.phase_pdf, e.pdf / float(lighting.x))
                                         : 1.0;
            p.L += path_weight(p) * e.L * w;
            p.done = true;
            return false;
        }
        if (!is_surface(hit.mesh) && dot(p.d, hit.normal) >= 0.0) {
            p.o = leave(hit, p.d);
            return false;
        }
        return true;
    }

    // Inside a medium: a free flight; the grid tells when it cannot reach the boundary.
    GpuShape s = shapes[p.shape];
    float sigma_t = p.channel < 0 ? s.sigma_t.x : s.sigma_t[p.channel];
    float t = sample_exponential(rng_uniform(p.rng), sigma_t);
    float r_o = p.r_at_o >= 0.0 ? p.r_at_o : path_grid_query(p, p.o);
    // A shrunk ball (below) that does not hold the flight: the grid may hold more.
    if (p.r_shrunk && !(t < r_o)) r_o = max(r_o, path_grid_query(p, p.o));
    p.r_shrunk = false;
    p.r_at_o = -1.0;
    vec3 end = p.o + p.d * t;
    float r_end = -1.0;
    bool at_boundary = false, ray_cast = false;
    if (!(t < r_o)) {
        if (t < kInf) r_end = path_grid_query(p, end);
        ray_cast = !(t < r_o + r_end);
        if (ray_cast) at_boundary = intersect(p.o, p.d, t, hit);
    }
    if (!at_boundary && (!(t < kInf) || (ray_cast && grid_cell_of(p.shape, end) < 0))) {
        // A numerical leak out of the mesh (pt.cpp): on along d from where it is.
        if (t < kInf) p.o = end;
        p.shape = -1;
        return false;
    }
    if (p.spectral) {
        vec3 f = hero_flight_ratio(s.sigma_t.xyz, p.channel, at_boundary ? hit.t : t,
                                   !at_boundary);
        p.ratio *= f;
        p.beta *= f;
    }
    if (!at_boundary) {
        p.o = end;
        // With spectral MIS, spectral_switch_extinction ("st": where a step fits it, the
        // path goes on in one channel, picked afresh; PathTracer::run).
        float sigma_step = p.spectral ? spectral_switch_extinction(s.sigma_t.xyz) : sigma_t;
        // The ball of radius r_o around the flight's start, shrunk by the flight, bounds
        // the distance at its end with no query; "st" takes it only where the grid's bound
        // allows no step anywhere in o's cell (PathTracer::run).
        float r = r_end;
        bool shrink = r < 0.0;
#if SSS_ST
        shrink = shrink && sigma_step * p.query_cell_bound < params.y + s.sigma_t.w &&
                 grid_cell_of(p.shape, p.o) == p.query_cell;
#endif
        if (shrink) {
            r = max(0.0, r_o - t * (1.0 + 1e-6) - grids[p.shape].scale.y);
            p.r_shrunk = true;
        } else if (r < 0.0) {
            r = path_grid_query(p, p.o);
        }
#if SSS_ST
        float r_step = step_radius(s, p.o, r, sigma_step);
        if (sigma_step * r_step >= params.y) {
            bool step = true;
            if (p.spectral) {  // then in the channel picked, if its sphere is thick enough
                to_one_channel(p);
                float sigma_c = s.sigma_t[p.channel];
                r_step = step_radius(s, p.o, r, sigma_c);
                step = sigma_c * r_step >= params.y;
            }
            if (step) {
                p.pending = true;  // one sphere step replaces the events inside the sphere
                p.r_step = r_step;
                return false;
            }
        }
        // Too close to the boundary for a sphere: a cut sphere step where a plane
        // certifies the region between it and the boundary (PathTracer::run).
        vec3 cut_n;
        float cut_s;
        if (CUTS && cut_certificate(p.shape, p.o, cut_n, cut_s)) {
            to_one_channel(p);
            p.pending = true;
            p.cut = true;
            p.cut_n = cut_n;
            p.r_step = cut_s;
            return false;
        }
#endif
        p.r_at_o = r;
        // Real collision: scatter.
        if (max_bounces >= 0 && int(p.events) >= max_bounces) {
            p.done = true;
            return false;
        }
        ++p.events;
        p.beta *= s.albedo.xyz;
        if (is_black(p.beta)) {
            p.done = true;
            return false;
        }
        if (NEE)
            p.L += path_weight(p) * direct_light(p.o, p.r_shrunk ? -1.0 : r, p.d, p.shape,
                                                 p.spectral ? -1 : p.channel, p.rng);
        vec3 d_new = phase_sample(phase_data(s), p.d, rng_uniform(p.rng), rng_uniform(p.rng));
        if (NEE) {  // for the MIS weight of a light this direction may hit
            p.phase_pdf = phase_eval(phase_data(s), dot(p.d, d_new));
            p.scatter_pos = p.o;
            p.specular = false;
        }
        p.d = d_new;
        if (!path_survives_roulette(p)) p.done = true;
        return false;
    }

    return true;
}

void path_iterate(inout Path p) {
    Hit hit;
    bool meet;
    if (p.gap != 0u) {
        hit = p.gap == 1u ? p.gap_on : p.gap_face;
        meet = true;
    } else {
        meet = fly(p, hit);
    }
    if (meet) meet_boundary(p, hit);
}

#if SSS_ST
// The sphere step a pending path waits for (PathTracer::request_step and take_step with
// StepNee::Hits): centre o, the radius r_step (step_radius), shrunk so that sigma_t r' <=
// sigma_max; no light sampling; survival phi^N, then the exit point and direction.
void path_sphere_step(inout Path p) {
    GpuShape s = shapes[p.shape];
    float sigma_t = p.channel < 0 ? s.sigma_t.x : s.sigma_t[p.channel];
    ++p.steps;
    p.pending = false;
    float sigma = min(sigma_t * p.r_step, params.z);
    float radius = min(p.r_step, sigma / sigma_t);
    // s.phase.y: Henyey-Greenstein's g (st takes only phase functions whose PhaseKind has
    // sphere_steps); no representative event, so no albedo for it.
    SphereStepSample st = sample_sphere_step(sigma, s.phase.y, 0.5, false, p.rng);
    Frame f = sphere_step_frame(p.d, rng_uniform(p.rng));
    p.beta *= vec3(survival_power(s.albedo.x, st.N), survival_power(s.albedo.y, st.N),
                   survival_power(s.albedo.z, st.N));
    if (is_black(p.beta)) {
        p.done = true;
        return;
    }
    p.o = p.o + frame_to_world(f, sphere_exit_point(st.cos_theta)) * radius;
    p.d = normalize(
        frame_to_world(f, sphere_exit_direction(st.cos_theta, st.alpha, st.beta)));
    p.specular = true;  // the exit flight's light hits count with weight 1
    if (!survives_roulette(p.beta, p.beta_start, p.rng)) p.done = true;
}

// The cut sphere step a pending path waits for (SphereTracing::cut_request, cut_to_world
// and PathTracer::take_step): the ball of the shape's radius, shrunk so that sigma_t R
// stays in the models' range, cut by the certificate's plane at distance r_step; no event
// (the media that take cut steps sample no lights from their events); survival phi^N,
// then the exit point and direction.
void path_cut_step(inout Path p) {
    GpuShape s = shapes[p.shape];
    float sigma_t = p.channel < 0 ? s.sigma_t.x : s.sigma_t[p.channel];
    ++p.steps;
    p.pending = false;
    p.cut = false;
    float radius = min(cut_grids[p.shape].params.x, cut_params.x / sigma_t);
    float sigma = min(sigma_t * radius, cut_params.x);
    float h = min(p.r_step / radius, 1.0);
    vec3 n = p.cut_n;
    float mu0 = clamp(dot(p.d, n), -1.0, 1.0);
    CutStepSample c = sample_cut_step(sigma, s.phase.y, h, mu0, p.rng);
    // The walk's frame in the world: z = n, x the part of the arriving direction across n
    // (any direction across n if none).
    vec3 x = p.d - n * mu0;
    float lx = length(x);
    x = lx > 1e-6 ? x / lx : frame_from_z(n).s;
    vec3 y = cross(n, x);
    p.beta *= vec3(survival_power(s.albedo.x, c.N), survival_power(s.albedo.y, c.N),
                   survival_power(s.albedo.z, c.N));
    if (is_black(p.beta)) {
        p.done = true;
        return;
    }
    p.o = p.o + (x * c.exit_pos.x + y * c.exit_pos.y + n * c.exit_pos.z) * radius;
    p.d = normalize(x * c.exit_dir.x + y * c.exit_dir.y + n * c.exit_dir.z);
    p.specular = true;  // as a sphere step's: its exit flight's light hits weigh 1
    if (!survives_roulette(p.beta, p.beta_start, p.rng)) p.done = true;
}

void path_step(inout Path p) {
    if (CUTS && p.cut)
        path_cut_step(p);
    else
        path_sphere_step(p);
}
#endif

// Path i of the dispatch from its camera ray (PinholeCamera::direction).
Path start_path(uint i) {
    uint width = counts.z, height = counts.w;
    uint pixel = i % (width * height), x = pixel % width, y = pixel / width;
    Path p;
    uint64_t seed = (uint64_t(seed_hi) << 32) | uint64_t(seed_lo);
    p.rng = rng_make(seed, uint64_t(pixel), uint64_t(sample0 + i / (width * height)));
    float fx = float(x) + rng_uniform(p.rng), fy = float(y) + rng_uniform(p.rng);
    float u = (2.0 * fx / float(width) - 1.0) * cam_origin.w * cam_forward.w;
    float v = (1.0 - 2.0 * fy / float(height)) * cam_origin.w;
    p.d = normalize(cam_forward.xyz + cam_right.xyz * u + cam_up.xyz * v);
    p.o = cam_origin.xyz + p.d * cam_right.w;
    p.L = vec3(0.0);
    p.beta = vec3(1.0);
    p.channel = -1;
    p.spectral = false;
    p.ratio = vec3(1.0);
    if (params.w == 0.0) {  // chromatic media: a hero channel, spectral MIS
        p.channel = min(2, int(rng_uniform(p.rng) * 3.0));
        p.spectral = true;
    }
    p.beta_start = max(p.beta.x, max(p.beta.y, p.beta.z));
    p.shape = -1;
    p.r_at_o = -1.0;
    p.r_shrunk = false;
    p.query_cell = -1;
    p.query_cell_bound = 0.0;
    p.specular = true;
    p.phase_pdf = 0.0;
    p.scatter_pos = vec3(0.0);
    p.events = 0u;
    p.steps = 0u;
    p.done = false;
    p.pending = false;
    p.r_step = 0.0;
    p.cut = false;
    p.cut_n = vec3(0.0);
    p.gap = 0u;
    return p;
}

// A lane whose path has ended writes it and starts its next, path id + lanes; false when
// it has none left.
bool next_path(inout Path p, inout uint id, uint lanes) {
    out_radiance[id] = vec4(p.L, 0.0);
    out_counts[id] = uvec2(p.events, p.steps | kGpuWritten);
    id += lanes;
    if (id >= num_paths) return false;
    p = start_path(id);
    return true;
}

void main() {
    const uint lanes = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint id = gl_GlobalInvocationID.x;
    Path p;
    p.done = true;
    p.pending = false;
    p.cut = false;
    if (id < num_paths) p = start_path(id);
#if SSS_ST
    // Sphere steps in batches: a path that needs a step waits until at least half of the
    // subgroup's lanes still running wait too; then they leave the inner loop together and
    // the decoders run once for all of them. Run one by one, the rare step of one lane
    // would stall its whole subgroup at nearly every iteration. The decoders stay out of
    // the inner loop, which is then as light as pt's. Each path draws from its own stream,
    // so the batching changes no result.
    while (id < num_paths) {
        while (true) {
            if (p.done && !next_path(p, id, lanes)) break;
            if (!p.pending) path_iterate(p);
            uint waiting = subgroupBallotBitCount(subgroupBallot(p.pending));
            uint busy = subgroupBallotBitCount(subgroupBallot(true));
            if (waiting > 0u && 2u * waiting >= busy) break;
        }
        if (p.pending) path_step(p);
    }
#else
    while (id < num_paths) {
        if (p.done && !next_path(p, id, lanes)) break;
        path_iterate(p);
    }
#endif
}

// The scene on the GPU (gpu/shaders/layout.h lays it out, gpu/gpu_scene.h fills it): camera, shapes, emitters, the
// flattened BVH (cpp/geometry/flat_bvh.h) and the distance grids. Closest-hit traversal
// and the grid's conservative bound, as RayTracer::intersect and DistanceGrid::query.

#include "gpu/shaders/scene_buffers.glsl"

const uint kLeafBit = 0x80000000u;
const uint kNoChild = 0xffffffffu;
const int kStackSize = 48;  // kBvhMaxDepth

struct Hit {
    float t;
    uint mesh;
    vec3 normal;  // outward unit normal of the triangle
    // The hit point rebuilt from the triangle and a bound on its rounding error, as
    // RayTracer::intersect (shared/ray_offset.h).
    vec3 p, p_error;
    // An opaque surface lies within the rays' offsets of the triangle
    // (Scene::touches_surface).
    bool touching;
};

// Slab test of the box [lo, hi] against the ray; the entry distance, or kInf for a miss.
// The exit distance is enlarged by 2 gamma(3) so that rounding never culls a box the ray
// touches (pbrt-v4's conservative box test).
float box_entry(vec3 lo, vec3 hi, vec3 o, vec3 inv_d, float tnear, float tfar) {
    vec3 t0 = (lo - o) * inv_d, t1 = (hi - o) * inv_d;
    vec3 tmin = min(t0, t1), tmax = max(t0, t1) * (1.0 + 2.0 * 1.7881397e-07);
    float enter = max(max(tmin.x, tmin.y), max(tmin.z, tnear));
    float leave = min(min(tmax.x, tmax.y), min(tmax.z, tfar));
    return enter <= leave ? enter : kInf;
}

// The ray in the form the watertight triangle test wants (Woop, Benthin and Wald,
// "Watertight Ray/Triangle Intersection", JCGT 2013): the axis of d's largest component
// becomes z, the others are sheared away. Shared edges then give both neighbours the same
// edge function, so no ray slips between two triangles (the test Embree's robust mode
// uses on the CPU).
struct ShearedRay {
    int kx, ky, kz;
    vec3 shear;  // Sx, Sy, Sz
};

ShearedRay shear_ray(vec3 d) {
    vec3 a = abs(d);
    ShearedRay r;
    r.kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    r.kx = (r.kz + 1) % 3;
    r.ky = (r.kx + 1) % 3;
    if (d[r.kz] < 0.0) {  // keep the winding
        int k = r.kx;
        r.kx = r.ky;
        r.ky = k;
    }
    r.shear = vec3(d[r.kx] / d[r.kz], d[r.ky] / d[r.kz], 1.0 / d[r.kz]);
    return r;
}

// Triangle (v0, v1, v2) against ray o + t d (sheared as r): t and the barycentric
// coordinates of v1 and v2, or false.
bool hit_triangle(vec3 o, ShearedRay r, vec3 v0, vec3 v1, vec3 v2, out float t,
                  out vec2 uv) {
    vec3 a = v0 - o, b = v1 - o, c = v2 - o;
    float ax = a[r.kx] - r.shear.x * a[r.kz], ay = a[r.ky] - r.shear.y * a[r.kz];
    float bx = b[r.kx] - r.shear.x * b[r.kz], by = b[r.ky] - r.shear.y * b[r.kz];
    float cx = c[r.kx] - r.shear.x * c[r.kz], cy = c[r.ky] - r.shear.y * c[r.kz];
    float u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    float det = u + v + w;
    if (det == 0.0) return false;
    float T = u * (r.shear.z * a[r.kz]) + v * (r.shear.z * b[r.kz]) + w * (r.shear.z * c[r.kz]);
    t = T / det;
    uv = vec2(v, w) / det;
    return true;
}

// Closest hit with t in (tnear, tfar) (the watertight test per triangle), passing
// through mesh `skip` (RayTracer::intersect_skipping; none: kNoMesh); false if none.
const uint kNoMesh = 0xffffffffu;
bool intersect_skipping(vec3 o, vec3 d, float tnear, float tfar, uint skip, out Hit hit) {
    // Avoid 0 * inf = NaN in the slabs: a zero component gets a huge inverse.
    vec3 inv_d = vec3(1.0) / mix(d, vec3(1e-30), equal(d, vec3(0.0)));
    ShearedRay sheared = shear_ray(d);
    uint stack[kStackSize];
    int sp = 0;
    uint node = 0u;
    int best = -1;
    float best_t = tfar;
    vec2 best_uv = vec2(0.0);
    for (;;) {
        if ((node & kLeafBit) != 0u) {
            uint first = node & 0x07ffffffu, count = ((node >> 27) & 15u) + 1u;
            for (uint i = first; i < first + count; ++i) {
                float t;
                vec2 uv;
                if (!hit_triangle(o, sheared, triangles[4 * i].xyz, triangles[4 * i + 1].xyz,
                                  triangles[4 * i + 2].xyz, t, uv))
                    continue;
                if (t > tnear && t < best_t && floatBitsToUint(triangles[4 * i].w) != skip) {
                    best_t = t;
                    best = int(i);
                    best_uv = uv;
                }
            }
        } else {
            vec4 n0 = nodes[4 * node], n1 = nodes[4 * node + 1], n2 = nodes[4 * node + 2];
            uvec2 child = floatBitsToUint(nodes[4 * node + 3].xy);
            float t0 = box_entry(n0.xyz, vec3(n0.w, n1.xy), o, inv_d, tnear, best_t);
            float t1 = child.y == kNoChild
                           ? kInf
                           : box_entry(vec3(n1.zw, n2.x), n2.yzw, o, inv_d, tnear, best_t);
            if (t0 < kInf && t1 < kInf) {
                // Both: the nearer first, the other on the stack.
                bool swap_order = t1 < t0;
                node = swap_order ? child.y : child.x;
                stack[sp++] = swap_order ? child.x : child.y;
                continue;
            }
            if (t0 < kInf) {
                node = child.x;
                continue;
            }
            if (t1 < kInf) {
                node = child.y;
                continue;
            }
        }
        if (sp == 0) break;
        node = stack[--sp];
    }
    if (best < 0) return false;
    hit.t = best_t;
    hit.mesh = floatBitsToUint(triangles[4 * best].w);
    hit.normal = triangles[4 * best + 3].xyz;
    hit.touching = triangles[4 * best + 3].w != 0.0;
    vec3 v0 = triangles[4 * best].xyz;
    hit.p = triangle_point(v0, triangles[4 * best + 1].xyz - v0,
                           triangles[4 * best + 2].xyz - v0, best_uv.x, best_uv.y, hit.p_error);
    return true;
}

// Closest hit with t in (tnear, tfar); false if none.
bool intersect_between(vec3 o, vec3 d, float tnear, float tfar, out Hit hit) {
    return intersect_skipping(o, d, tnear, tfar, kNoMesh, hit);
}

// Closest hit with t in (0, tfar).
bool intersect(vec3 o, vec3 d, float tfar, out Hit hit) {
    return intersect_skipping(o, d, 0.0, tfar, kNoMesh, hit);
}

// DistanceGrid::locate: p's cell c in shape's grid and its coordinates in cells g; false
// outside the grid (or where the shape has none).
bool grid_locate(GpuGrid gr, vec3 p, out vec3 g, out ivec3 c) {
    c = ivec3(0);
    g = (p - gr.origin.xyz) * gr.scale.x;
    if (gr.n.x == 0 || !(g.x >= 0.0 && g.y >= 0.0 && g.z >= 0.0)) return false;
    if (!(g.x < float(gr.n.x - 1) && g.y < float(gr.n.y - 1) && g.z < float(gr.n.z - 1)))
        return false;
    c = ivec3(g);
    return c.x < gr.n.x - 1 && c.y < gr.n.y - 1 && c.z < gr.n.z - 1;
}

// Where cell c's first node lies in scene_floats: a cell's name, unique over all shapes.
int grid_cell_index(GpuGrid gr, ivec3 c) {
    return gr.n.w + (c.z * gr.n.y + c.y) * gr.n.x + c.x;
}

// DistanceGrid::query: a lower bound on the distance from p to shape's surface (0
// outside its grid): max over the cell's 8 nodes of d(node) - |p - node|, less the guard.
// Also p's cell (grid_cell_index; -1 outside the grid) and its largest node distance,
// which bounds the query over the whole cell (0 outside).
float grid_query_in_cell(int shape, vec3 p, out int cell, out float cell_bound) {
    cell = -1;
    cell_bound = 0.0;
    GpuGrid gr = grids[shape];
    vec3 g;
    ivec3 c;
    if (!grid_locate(gr, p, g, c)) return 0.0;
    vec3 f = g - vec3(c);
    vec3 q0 = f * f, q1 = (1.0 - f) * (1.0 - f);
    int base = grid_cell_index(gr, c);
    int slab = gr.n.x * gr.n.y;
    float r = -kInf;
    for (int k = 0; k < 2; ++k) {
        for (int j = 0; j < 2; ++j) {
            int row = base + k * slab + j * gr.n.x;
            float yz = (j == 0 ? q0.y : q1.y) + (k == 0 ? q0.z : q1.z);
            float d0 = scene_floats[row], d1 = scene_floats[row + 1];
            r = max(r, d0 - gr.origin.w * sqrt(q0.x + yz));
            r = max(r, d1 - gr.origin.w * sqrt(q1.x + yz));
            cell_bound = max(cell_bound, max(d0, d1));
        }
    }
    cell = base;
    return max(0.0, r - gr.scale.y);
}

float grid_query(int shape, vec3 p) {
    int cell;
    float cell_bound;
    return grid_query_in_cell(shape, p, cell, cell_bound);
}

// DistanceGrid::cell_of: p's cell as grid_query_in_cell names it, -1 outside the grid.
int grid_cell_of(int shape, vec3 p) {
    GpuGrid gr = grids[shape];
    vec3 g;
    ivec3 c;
    return grid_locate(gr, p, g, c) ? grid_cell_index(gr, c) : -1;
}

// Boundary ray queries with Embree 3: the closest hit, and every crossing of a segment
// (shadow rays), against the triangle meshes of a scene. The device and scene are owned
// here and released in the destructor; geometry is added before commit() and the scene is
// read-only (and thread-safe) afterwards.
#pragma once

#include <memory>
#include <vector>

#include "core/vec.h"
#include "geometry/mesh.h"

namespace sss {

struct Hit {
    float t = 0.f;
    Vec3 normal;  // outward unit normal of the hit triangle (counter-clockwise winding)
    unsigned mesh = 0;  // index in the order meshes were added
    unsigned prim = 0;  // triangle index within that mesh
    // The hit point, rebuilt from the triangle and the barycentric coordinates (not
    // o + t d, whose error grows with |o| and t), and a bound on its rounding error: rays
    // leaving it start at offset_ray_origin(p, p_error, normal, w) (shared/ray_offset.h).
    Vec3 p, p_error;
};

// One surface a segment crosses (RayTracer::crossings).
struct Crossing {
    float t = 0.f;
    unsigned mesh = 0, prim = 0;
    Vec3 normal;  // outward unit normal of the triangle
};

class RayTracer {
public:
    RayTracer();
    ~RayTracer();
    RayTracer(const RayTracer&) = delete;
    RayTracer& operator=(const RayTracer&) = delete;

    // Copies the mesh into Embree buffers; returns its index. Only before commit().
    unsigned add_mesh(const TriangleMesh& mesh);
    void commit();

    // Closest hit with t in (tnear, tfar); false if none.
    bool intersect(const Vec3& o, const Vec3& d, float tnear, float tfar, Hit* hit) const;
    // The same, passing through mesh `skip`: what else lies where that mesh was hit.
    bool intersect_skipping(const Vec3& o, const Vec3& d, float tnear, float tfar,
                            unsigned skip, Hit* hit) const;
    // Every triangle the segment t in (0, tfar) crosses, nearest first, in one traversal:
    // writes out[0 .. count) and returns count, or -1 when there are more than `max`.
    int crossings(const Vec3& o, const Vec3& d, float tfar, Crossing* out, int max) const;

private:
    struct Impl;
    // The closest hit through `context`, an RTCIntersectContext* (void* here: Embree's
    // headers stay out of ours).
    bool closest(const Vec3& o, const Vec3& d, float tnear, float tfar, void* context,
                 Hit* hit) const;
    std::unique_ptr<Impl> impl_;
};

}  // namespace sss

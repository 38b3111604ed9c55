// Triangle meshes: loading (OBJ, PLY, OFF, STL), validation and orientation. Every mesh
// that holds a medium is closed, free of degenerate triangles, and oriented so that
// counter-clockwise winding gives the outward normal; an opaque surface's mesh may be
// open (MeshKind::Open), and is then neither checked for closure nor oriented.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec.h"

namespace sss {

struct TriangleMesh {
    std::vector<Vec3> positions;  // relative to `origin`
    std::vector<std::array<uint32_t, 3>> triangles;
    // Where `positions` are measured from, in double: a mesh file far from 0 keeps its
    // placement here, so its shape is not rounded to the float step of its coordinates.
    Vec3d origin;

    Bounds3 bounds() const;
    // Outward unit normal of triangle i (counter-clockwise winding).
    Vec3 normal(size_t i) const;
    double area() const;
    double volume() const;  // signed; > 0 for an outward-oriented closed mesh
};

// Appends the triangles of `from` whose bounds overlap `keep` to `to` (both in the same
// frame).
void append_mesh(TriangleMesh& to, const TriangleMesh& from, const Bounds3& keep);

// For each triangle, a bound on how far from its plane a ray leaving it starts:
// offset_ray_origin at a hit point that triangle_point rebuilt (shared/ray_offset.h),
// which grows with the coordinates. Two media closer than that could swap sides.
std::vector<double> ray_offset_bounds(const TriangleMesh& mesh);
// A bound on every such bound of the triangles within `box` (from the box alone).
double ray_offset_ceiling(const Bounds3& box);

enum class MeshKind { Closed, Open };

// Reads a polygon mesh from `path` (by extension: .obj .ply .off .stl), triangulates it
// and hands it to make_closed_mesh (or make_open_mesh). Throws sss::Error naming the file
// and the problem.
TriangleMesh load_mesh(const std::string& path, MeshKind kind = MeshKind::Closed);

// Validates and orients a polygon soup (`what` names it in errors): duplicate vertices
// are merged; degenerate (zero-area) triangles, open boundaries, non-manifold edges and
// zero volume are refused; faces are re-oriented consistently and outward. The checks
// run on the positions as given, in double; the mesh keeps them relative to `origin`
// (TriangleMesh::origin), rounded to float.
TriangleMesh make_closed_mesh(const std::vector<Vec3d>& positions,
                              std::vector<std::vector<uint32_t>> polygons,
                              const std::string& what, Vec3d origin = Vec3d());

// The same checks short of closure, orientation and volume, for opaque surfaces: merged
// vertices, no degenerate triangles, the winding as given.
TriangleMesh make_open_mesh(const std::vector<Vec3d>& positions,
                            std::vector<std::vector<uint32_t>> polygons,
                            const std::string& what, Vec3d origin = Vec3d());

// The centre of the points' bounding box: the origin a file's mesh is kept relative to.
Vec3d center_of_bounds(const std::vector<Vec3d>& points);
// ... of the points the polygons use: a vertex no face uses (dropped when the mesh is
// made) must not move the origin, whose float rounding the mesh's positions take (one
// 3e7 away moved a unit cube by 0.15, one 1e10 away collapsed it).
Vec3d center_of_bounds(const std::vector<Vec3d>& points,
                       const std::vector<std::vector<uint32_t>>& polygons);

// Throws sss::Error (naming `what`) unless the closed mesh encloses a volume above 1e-9
// of its bounding box's largest side cubed: flat meshes, or meshes made flat by float
// rounding, have no inside (and hang CGAL's inside test).
void check_encloses_volume(const TriangleMesh& mesh, const std::string& what);

// Icosphere: the icosahedron subdivided `subdivisions` times, vertices on the sphere.
TriangleMesh make_icosphere(Vec3 center, float radius, int subdivisions);

// A similarity-like transform of scene files: p -> p * scale (per axis), then rotations
// about x, y, z (degrees, in that order), then + translate; in double precision.
struct Transform {
    Vec3d scale{1, 1, 1}, rotate_deg, translate;
    Vec3d apply(Vec3d p) const;
    bool mirrors() const { return scale.x * scale.y * scale.z < 0; }
};

// The mesh's positions (origin included) under `transform`, in double precision (the
// caller moves them into the render frame); a mirroring transform flips the triangles'
// winding back outward.
std::vector<Vec3d> transform_mesh(TriangleMesh& mesh, const Transform& transform);

// Uniform scale so that the largest bounding-box side is 1, centred at the origin.
void normalize_mesh(TriangleMesh& mesh);

}  // namespace sss

// A conservative distance field to a closed mesh (docs/notation.md, "Distance grid"):
// exact point-to-triangle distances (CGAL AABB tree) at the nodes of a regular grid over
// the mesh bounds, and at query time the 1-Lipschitz bound  r(p) = max_corners( d(node) -
// |p - node| ),  which is never larger than the true distance from p to the surface.
#pragma once

#include <cstdint>
#include <vector>

#include "core/cancel.h"
#include "core/vec.h"
#include "geometry/mesh.h"

namespace sss {

class DistanceGrid {
public:
    DistanceGrid() = default;

    // `resolution`: cells along the largest side of the mesh bounds (>= 2). The grid is
    // padded by one cell on every side. Built with `threads` workers (0 = all cores).
    //
    // Up to `exact_up_to` cells every node's distance is exact (rounded down). A finer
    // grid starts from one of half its resolution (built the same way) and computes
    // exact distances only where the paths need the finer bound: at nodes less than
    // kRefineBand of the coarse grid's cell diagonals from the surface, or on its outside
    // within our own diagonal. A deeper node inside keeps the coarse grid's bound (a
    // valid lower bound, as tight as that grid's), a farther node outside holds the
    // diagonal as before, and the side of every node stays exact. Near the surface the
    // grid is the exact one, bit for bit; the build costs about the coarse grid's, not 8
    // times it.
    static constexpr int kExactResolution = 64;
    static constexpr float kRefineBand = 1.f;
    // `stop` is polled before each row of nodes (one y and z), well under a millisecond;
    // once it returns true the build throws Cancelled (core/cancel.h).
    //
    // `obstacles`: opaque surfaces that reach into the medium (a floor through it, a wick
    // inside it). Distances are to the nearest of the mesh and them, so that a ball the
    // grid certifies holds neither; inside and outside are the mesh's alone.
    static DistanceGrid build(const TriangleMesh& mesh, int resolution, int threads = 0,
                              int exact_up_to = kExactResolution, const StopFn& stop = {},
                              const TriangleMesh& obstacles = TriangleMesh{});

    // Lower bound on the distance from p to the mesh surface; 0 outside the grid.
    float query(const Vec3& p) const;
    // The same, and p's cell (-1 outside the grid) with an upper bound on query() over
    // that whole cell: its largest corner distance (0 outside the grid). cell_of(q) ==
    // *cell tells that q lies in the same cell, so query(q) <= *cell_bound without a
    // query.
    float query(const Vec3& p, int64_t* cell, float* cell_bound) const;
    int64_t cell_of(const Vec3& p) const;
    // An upper bound on query(p) over all p (the largest node distance).
    float max_query() const;
    // Whether p is inside the closed mesh, by the sign stored at the nearest node: a
    // guess (wrong for some points within a cell of the surface); side() tells when it is
    // sure.
    bool inside(const Vec3& p) const;
    // Which side of the mesh p is on where the grid can tell exactly: +1 inside, -1
    // outside, 0 unknown. It can when a corner node of p's cell is farther from the
    // surface than from p (the ball about that node reaches p without crossing the
    // surface, so p is on the node's side); 0 for points outside the grid.
    int side(const Vec3& p) const;

    // Unsigned distance at node (i, j, k), rounded down to a float: exact for nodes
    // inside the mesh and for those within a cell diagonal of the surface; a node outside
    // and farther away holds the diagonal (it is a corner only of cells wholly outside).
    // And whether that node lies inside.
    float node_distance(int i, int j, int k) const { return dist_[index(i, j, k)]; }
    bool node_inside(int i, int j, int k) const { return inside_[index(i, j, k)] != 0; }
    Vec3 node_position(int i, int j, int k) const {
        return origin_ + Vec3(float(i), float(j), float(k)) * cell_;
    }
    int nx() const { return n_[0]; }
    int ny() const { return n_[1]; }
    int nz() const { return n_[2]; }
    float cell_size() const { return cell_; }
    Vec3 origin() const { return origin_; }  // node (0, 0, 0)
    // What query() subtracts from every bound (float rounding; see guard_ below).
    float guard() const { return guard_; }
    // Every node's distance, node (i, j, k) at (k * ny + j) * nx + i (the GPU path's
    // copy).
    const std::vector<float>& node_distances() const { return dist_; }
    bool empty() const { return dist_.empty(); }

private:
    // p's cell (i, j, k) and its coordinates in cells g; false outside the grid.
    bool locate(const Vec3& p, Vec3* g, int* i, int* j, int* k) const;
    float query_impl(const Vec3& p, int64_t* cell, float* cell_bound) const;
    size_t index(int i, int j, int k) const {
        return (size_t(k) * n_[1] + j) * n_[0] + i;
    }

    Vec3 origin_;
    float cell_ = 0.f, inv_cell_ = 0.f;
    // Subtracted from every bound: covers float rounding in p - node (a few ulps of the
    // grid's coordinates) and in the bound's arithmetic.
    float guard_ = 0.f;
    int n_[3] = {0, 0, 0};  // nodes per axis
    std::vector<float> dist_;
    std::vector<uint8_t> inside_;
};

// Whether p lies inside the closed mesh, or on it (exact predicate; builds an AABB tree
// per call).
bool point_inside_mesh(const TriangleMesh& mesh, Vec3 p);
std::vector<bool> points_inside_mesh(const TriangleMesh& mesh,
                                     const std::vector<Vec3>& points);

// Whether two meshes meet (exact predicates): their triangles cross or touch, or one lies
// inside the closed mesh `closed`; or, if `other_closed`, `closed` lies inside `other`.
bool meshes_meet(const TriangleMesh& closed, const TriangleMesh& other,
                 bool other_closed);

// Two meshes that do not meet (meshes_meet false) may still be too close: a ray leaving
// one starts a rounding-sized distance past its surface (shared/ray_offset.h), and
// within that distance of the other it can start past the other's surface too. The pair
// of triangles nearest to that, with a margin of 2 on the offsets: its gap and the gap it
// needs; {inf, 0} when every pair is far enough apart.
struct NearContact {
    double gap = INFINITY, needed = 0;
};
NearContact near_contact(const TriangleMesh& a, const TriangleMesh& b);

// How an opaque surface meets a closed medium, for the tracers: the medium's triangles
// that a surface triangle comes within the rays' offsets of (where a ray that hits the
// medium's face may as well have hit the surface: a cube resting on a floor, a ball
// touching it, a floor through a cube along the sides it cuts), and whether the surface
// lies inside the medium touching none of them (a wick in a candle).
struct SurfaceContact {
    std::vector<uint32_t> touching;  // ascending
    bool inside = false;
    bool meets() const { return inside || !touching.empty(); }
};
SurfaceContact surface_contact(const TriangleMesh& medium, const TriangleMesh& surface);

// Exact distance from p to the mesh (for tests and tools; builds an AABB tree per call).
std::vector<double> exact_distances(const TriangleMesh& mesh,
                                    const std::vector<Vec3>& points);

}  // namespace sss

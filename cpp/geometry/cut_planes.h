// Plane certificates for cut sphere steps (docs/notation.md, "The cut sphere problem";
// issue 26). For every cell of a shape's distance grid within reach of the surface: a
// unit normal n (towards the nearest surface) and an offset m such that every surface
// point y within radius + half a cell diagonal of the cell's centre c has (y - c) . n >=
// m. A point p of the cell then gets the plane distance
//     s(p) = m - (p - c) . n - guard,
// and the region { |y - p| <= radius, (y - p) . n <= s(p) } holds no surface point: it is
// convex, contains p (where s(p) > 0), and so lies wholly in p's medium. Any n gives a
// valid certificate; the nearest surface's direction makes s large.
//
// m is a lower bound: the smallest (v - c) . n over the vertices of every triangle within
// radius + half a diagonal of c, and never below -(radius + half diagonal) (the ball's
// own bound). Exact for flat faces; on a curved mesh the vertices just outside the ball
// make it lower by up to the sagitta over an edge more.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/vec.h"
#include "geometry/distance_grid.h"
#include "geometry/mesh.h"

namespace sss {

class CutPlanes {
public:
    CutPlanes() = default;

    // Certificates for balls of up to `radius` (> 0) in the cells of `grid` (built for
    // `mesh` and `obstacles`) that have a corner inside the mesh and within radius + a
    // cell diagonal of the surface. A certificate's plane has the obstacles' triangles
    // within reach behind it too. Built with `threads` workers (0 = all cores).
    static CutPlanes build(const TriangleMesh& mesh, const DistanceGrid& grid,
                           float radius, int threads = 0,
                           const TriangleMesh& obstacles = TriangleMesh{});

    // The certificate at p: false where p's cell has none (then n and s are left alone).
    bool query(const Vec3& p, Vec3* n, float* s) const {
        const Vec3 q = (p - origin_) * inv_cell_;
        if (!(q.x >= 0.f && q.y >= 0.f && q.z >= 0.f && q.x < float(n_[0]) &&
              q.y < float(n_[1]) && q.z < float(n_[2])))
            return false;  // compared before int(), which is undefined past INT_MAX
        const int i = int(q.x), j = int(q.y), k = int(q.z);
        const int32_t e = index_[(size_t(k) * n_[1] + j) * n_[0] + i];
        if (e < 0) return false;
        const Entry& c = entries_[size_t(e)];
        *n = c.n;
        *s = c.m - dot(p - c.centre, c.n) - guard_;
        return true;
    }

    float radius() const { return radius_; }
    size_t cells() const { return entries_.size(); }
    bool empty() const { return entries_.empty(); }

    // The certificates as query() reads them, for copies elsewhere (the GPU's scene,
    // gpu/gpu_scene_bake.h): cell (i, j, k) of p = origin + (i, j, k) cell_size has
    // index()[(k ny + j) nx + i] (-1: none) into entries().
    struct Entry {
        Vec3 centre, n;
        float m = 0.f;
    };
    Vec3 origin() const { return origin_; }
    float cell_size() const { return cell_; }
    float guard() const { return guard_; }
    int cells_along(int axis) const { return n_[axis]; }
    const std::vector<int32_t>& index() const { return index_; }
    const std::vector<Entry>& entries() const { return entries_; }

private:
    Vec3 origin_;
    float cell_ = 0.f, inv_cell_ = 0.f, radius_ = 0.f, guard_ = 0.f;
    int n_[3] = {0, 0, 0};        // cells per axis
    std::vector<int32_t> index_;  // per cell: its entry, or -1
    std::vector<Entry> entries_;
};

}  // namespace sss

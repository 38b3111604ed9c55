#include "geometry/distance_grid.h"

#include <hwy/highway.h>

#include <algorithm>
#include <cmath>

namespace sss {

namespace hn = hwy::HWY_NAMESPACE;  // the build's baseline target (SSE4 on x86-64-v2)

inline bool DistanceGrid::locate(const Vec3& p, Vec3* g, int* i, int* j, int* k) const {
    if (dist_.empty()) return false;
    *g = (p - origin_) * inv_cell_;
    // Compared before the conversion: int() of a float past INT_MAX is undefined (a point
    // 1e8 away gave a negative cell index).
    if (!(g->x >= 0.f && g->y >= 0.f && g->z >= 0.f && g->x < float(n_[0] - 1) &&
          g->y < float(n_[1] - 1) && g->z < float(n_[2] - 1)))
        return false;
    *i = int(g->x), *j = int(g->y), *k = int(g->z);
    return true;
}

// What query() computes, and where `cell` is not null also p's cell (-1 outside the grid)
// and the largest distance at its corners, which bounds query() over the whole cell.
inline float DistanceGrid::query_impl(const Vec3& p, int64_t* cell,
                                      float* cell_bound) const {
    if (cell) *cell = -1, *cell_bound = 0.f;
    Vec3 g;
    int i, j, k;
    if (!locate(p, &g, &i, &j, &k)) return 0.f;
    // Squared distances from p to the cell's two node planes on each axis, in cells.
    const float fx = g.x - float(i), fy = g.y - float(j), fz = g.z - float(k);
    const float x0 = fx * fx, x1 = (1.f - fx) * (1.f - fx);
    const float y0 = fy * fy, y1 = (1.f - fy) * (1.f - fy);
    const float z0 = fz * fz, z1 = (1.f - fz) * (1.f - fz);
    // The eight corners as two vectors, (i, i+1) x (j, j+1) at k and at k + 1. Each gives
    // a valid lower bound d(node) - |p - node| (distance is 1-Lipschitz); keep the best.
    const size_t first = index(i, j, k);
    const float* a = &dist_[first];
    const float* b = a + n_[0];
    const size_t slab = size_t(n_[0]) * size_t(n_[1]);
    const hn::FixedTag<float, 4> v;
    alignas(16) const float xy[4] = {x0 + y0, x1 + y0, x0 + y1, x1 + y1};
    alignas(16) const float d_k0[4] = {a[0], a[1], b[0], b[1]};
    alignas(16) const float d_k1[4] = {a[slab], a[slab + 1], b[slab], b[slab + 1]};
    const auto h = hn::Set(v, cell_), s_xy = hn::Load(v, xy);
    const auto n_k0 = hn::Load(v, d_k0), n_k1 = hn::Load(v, d_k1);
    const auto r_k0 = hn::NegMulAdd(h, hn::Sqrt(hn::Add(s_xy, hn::Set(v, z0))), n_k0);
    const auto r_k1 = hn::NegMulAdd(h, hn::Sqrt(hn::Add(s_xy, hn::Set(v, z1))), n_k1);
    const float r = hn::GetLane(hn::MaxOfLanes(v, hn::Max(r_k0, r_k1)));
    if (cell) {
        *cell = int64_t(first);
        *cell_bound = hn::GetLane(hn::MaxOfLanes(v, hn::Max(n_k0, n_k1)));
    }
    return std::max(0.f, r - guard_);
}

float DistanceGrid::query(const Vec3& p) const { return query_impl(p, nullptr, nullptr); }

float DistanceGrid::query(const Vec3& p, int64_t* cell, float* cell_bound) const {
    return query_impl(p, cell, cell_bound);
}

int64_t DistanceGrid::cell_of(const Vec3& p) const {
    Vec3 g;
    int i, j, k;
    return locate(p, &g, &i, &j, &k) ? int64_t(index(i, j, k)) : -1;
}

float DistanceGrid::max_query() const {
    float m = 0.f;
    for (float d : dist_) m = std::max(m, d);
    return m;
}

bool DistanceGrid::inside(const Vec3& p) const {
    if (dist_.empty()) return false;
    Vec3 g = (p - origin_) * inv_cell_ + Vec3(0.5f);
    if (!(g.x >= 0.f && g.y >= 0.f && g.z >= 0.f && g.x < float(n_[0]) &&
          g.y < float(n_[1]) && g.z < float(n_[2])))
        return false;  // compared before int(), as in locate()
    return inside_[index(int(g.x), int(g.y), int(g.z))] != 0;
}

int DistanceGrid::side(const Vec3& p) const {
    Vec3 g;
    int i, j, k;
    if (!locate(p, &g, &i, &j, &k)) return 0;
    for (int c = 0; c < 8; ++c) {
        const int a = i + (c & 1), b = j + ((c >> 1) & 1), e = k + ((c >> 2) & 1);
        const size_t n = index(a, b, e);
        // The node's distance is rounded down and p - node rounded: keep the guard's
        // margin.
        if (dist_[n] - length(p - node_position(a, b, e)) > guard_)
            return inside_[n] ? 1 : -1;
    }
    return 0;
}

}  // namespace sss

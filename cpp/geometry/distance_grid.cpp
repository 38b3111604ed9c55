#include "geometry/distance_grid.h"

#include <algorithm>
#include <cmath>

namespace sss {

float DistanceGrid::query(const Vec3& p) const {
    if (dist_.empty()) return 0.f;
    Vec3 g = (p - origin_) / cell_;
    if (!(g.x >= 0.f && g.y >= 0.f && g.z >= 0.f)) return 0.f;
    int i = int(g.x), j = int(g.y), k = int(g.z);
    if (i >= n_[0] - 1 || j >= n_[1] - 1 || k >= n_[2] - 1) return 0.f;
    // Each corner gives a valid lower bound (distance is 1-Lipschitz); keep the best.
    float r = 0.f;
    for (int c = 0; c < 8; ++c) {
        int ii = i + (c & 1), jj = j + ((c >> 1) & 1), kk = k + ((c >> 2) & 1);
        float d = dist_[index(ii, jj, kk)] - length(p - node_position(ii, jj, kk));
        r = std::max(r, d);
    }
    // Guard against float rounding in |p - node| and the node position itself.
    return std::max(0.f, r * (1.f - 1e-5f) - 1e-6f * cell_);
}

float DistanceGrid::max_query() const {
    float m = 0.f;
    for (float d : dist_) m = std::max(m, d);
    return m;
}

bool DistanceGrid::inside(const Vec3& p) const {
    if (dist_.empty()) return false;
    Vec3 g = (p - origin_) / cell_ + Vec3(0.5f);
    if (!(g.x >= 0.f && g.y >= 0.f && g.z >= 0.f)) return false;
    int i = int(g.x), j = int(g.y), k = int(g.z);
    if (i >= n_[0] || j >= n_[1] || k >= n_[2]) return false;
    return inside_[index(i, j, k)] != 0;
}

}  // namespace sss

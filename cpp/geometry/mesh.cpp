// Mesh utilities that need no CGAL (the CGAL code lives in cgal.cpp alone: it is slow to
// compile).
#include "geometry/mesh.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "core/check.h"
#include "shared/ray_offset.h"

namespace sss {

Bounds3 TriangleMesh::bounds() const {
    Bounds3 b;
    for (const Vec3& p : positions) b.extend(p);
    return b;
}

Vec3 TriangleMesh::normal(size_t i) const {
    const auto& t = triangles[i];
    Vec3 n = cross(positions[t[1]] - positions[t[0]], positions[t[2]] - positions[t[0]]);
    return unit_normal(n);
}

double TriangleMesh::area() const {
    double a = 0;
    for (size_t i = 0; i < triangles.size(); ++i) {
        // In double: a float cross product's squared length overflows for long edges.
        const auto& t = triangles[i];
        const Vec3d p0(positions[t[0]]), e1 = Vec3d(positions[t[1]]) - p0,
                                         e2 = Vec3d(positions[t[2]]) - p0;
        const double cx = e1.y * e2.z - e1.z * e2.y, cy = e1.z * e2.x - e1.x * e2.z,
                     cz = e1.x * e2.y - e1.y * e2.x;
        a += 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
    }
    return a;
}

double ray_offset_ceiling(const Bounds3& box) {
    double norm = 0, ulp = 0;
    for (int c = 0; c < 3; ++c) {
        const double lo = (&box.lo.x)[c], hi = (&box.hi.x)[c];
        const double m = std::max(std::abs(lo), std::abs(hi));
        const double error = kGamma7 * (m + (hi - lo));
        norm += error * error;
        ulp += (m + error) * (m + error);
    }
    return 2 * std::sqrt(norm) + std::ldexp(std::sqrt(ulp), -22);
}

void append_mesh(TriangleMesh& to, const TriangleMesh& from, const Bounds3& keep) {
    SSS_CHECK(from.origin.x == to.origin.x && from.origin.y == to.origin.y &&
              from.origin.z == to.origin.z);
    const auto base = uint32_t(to.positions.size());
    to.positions.insert(to.positions.end(), from.positions.begin(), from.positions.end());
    for (const auto& t : from.triangles) {
        Bounds3 b;
        for (uint32_t v : t) b.extend(from.positions[v]);
        if (b.overlaps(keep))
            to.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    }
}

std::vector<double> ray_offset_bounds(const TriangleMesh& mesh) {
    std::vector<double> bounds;
    bounds.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles) {
        const Vec3d v[3] = {Vec3d(mesh.positions[t[0]]), Vec3d(mesh.positions[t[1]]),
                            Vec3d(mesh.positions[t[2]])};
        // triangle_point's error bound is kGamma7 (|v0| + |b1 e1| + |b2 e2|), whichever
        // corner Embree takes for v0: at most kGamma7 (m + e) per axis (b1 + b2 <= 1), m
        // the largest |coordinate| and e the triangle's extent.
        Vec3d error, m;
        for (int c = 0; c < 3; ++c) {
            const double lo = std::min({v[0][c], v[1][c], v[2][c]}),
                         hi = std::max({v[0][c], v[1][c], v[2][c]});
            m[c] = std::max(std::abs(lo), std::abs(hi));
            error[c] = kGamma7 * (m[c] + (hi - lo));
        }
        const Vec3d e1 = v[1] - v[0], e2 = v[2] - v[0];
        Vec3d n(e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z,
                e1.x * e2.y - e1.y * e2.x);
        const double length = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
        const double norm =
            std::sqrt(error.x * error.x + error.y * error.y + error.z * error.z);
        // Rounding p + offset, then one float further: up to 1.5 floats per coordinate
        // (2 taken, which also covers Embree's float normal against the exact one).
        const double ulp = std::ldexp(std::sqrt((m.x + error.x) * (m.x + error.x) +
                                                (m.y + error.y) * (m.y + error.y) +
                                                (m.z + error.z) * (m.z + error.z)),
                                      -22);
        if (!(length > 0) ||
            !std::isfinite(length)) {  // no normal in float: any direction
            bounds.push_back(2 * norm + ulp);
            continue;
        }
        n = n * (1 / length);
        // offset_ray_origin moves the hit point by its error along n; where that is 0 (a
        // corner whose coordinates are 0 on every axis n has a part of), by the largest
        // error instead.
        double along = 0, most = 0;
        bool may_fall_back = false;
        for (int c = 0; c < 3; ++c) {
            along += std::abs(n[c]) * error[c];
            most = std::max(most, error[c]);
        }
        for (const Vec3d& p : v)
            may_fall_back =
                may_fall_back || ((n.x == 0 || p.x == 0) && (n.y == 0 || p.y == 0) &&
                                  (n.z == 0 || p.z == 0));
        // The hit point itself may lie `along` off the plane, to the same side.
        bounds.push_back(along + (may_fall_back ? std::max(along, most) : along) + ulp);
    }
    return bounds;
}

double TriangleMesh::volume() const {
    // Divergence theorem: sum of signed tetrahedra with the origin, in double.
    double v = 0;
    for (const auto& t : triangles) {
        Vec3 a = positions[t[0]], b = positions[t[1]], c = positions[t[2]];
        double ax = a.x, ay = a.y, az = a.z, bx = b.x, by = b.y, bz = b.z, cx = c.x,
               cy = c.y, cz = c.z;
        v += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) +
             az * (bx * cy - by * cx);
    }
    return v / 6.0;
}

TriangleMesh make_icosphere(Vec3 center, float radius, int subdivisions) {
    if (!(radius > 0.f) || !std::isfinite(radius))
        fail("sphere radius must be > 0, got ", radius);
    const float t = (1.f + std::sqrt(5.f)) / 2.f;
    std::vector<Vec3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                           {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                           {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    for (Vec3& v : p) v = normalize(v);
    std::vector<std::array<uint32_t, 3>> f = {
        {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
        {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
        {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
        {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (int level = 0; level < subdivisions; ++level) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;
        auto mid = [&](uint32_t a, uint32_t b) {
            auto key = std::minmax(a, b);
            auto it = midpoint.find(key);
            if (it != midpoint.end()) return it->second;
            p.push_back(normalize(p[a] + p[b]));
            return midpoint[key] = uint32_t(p.size() - 1);
        };
        std::vector<std::array<uint32_t, 3>> next;
        next.reserve(f.size() * 4);
        for (const auto& tri : f) {
            uint32_t a = mid(tri[0], tri[1]), b = mid(tri[1], tri[2]),
                     c = mid(tri[2], tri[0]);
            next.push_back({tri[0], a, c});
            next.push_back({tri[1], b, a});
            next.push_back({tri[2], c, b});
            next.push_back({a, b, c});
        }
        f.swap(next);
    }
    TriangleMesh mesh;
    mesh.positions.reserve(p.size());
    for (const Vec3& v : p) mesh.positions.push_back(center + v * radius);
    mesh.triangles = std::move(f);
    return mesh;
}

Vec3d Transform::apply(Vec3d p) const {
    Vec3d q(p.x * scale.x, p.y * scale.y, p.z * scale.z);
    for (int axis = 0; axis < 3; ++axis) {
        if (rotate_deg[axis] == 0) continue;
        const double a = rotate_deg[axis] * 0.017453292519943295, c = std::cos(a),
                     s = std::sin(a);
        if (axis == 0)
            q = {q.x, c * q.y - s * q.z, s * q.y + c * q.z};
        else if (axis == 1)
            q = {c * q.x + s * q.z, q.y, -s * q.x + c * q.z};
        else
            q = {c * q.x - s * q.y, s * q.x + c * q.y, q.z};
    }
    return q + translate;
}

std::vector<Vec3d> transform_mesh(TriangleMesh& mesh, const Transform& transform) {
    std::vector<Vec3d> world;
    world.reserve(mesh.positions.size());
    for (const Vec3& p : mesh.positions)
        world.push_back(transform.apply(mesh.origin + Vec3d(p)));
    if (transform.mirrors())
        for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
    return world;
}

void normalize_mesh(TriangleMesh& mesh) {
    Bounds3 b = mesh.bounds();
    float side = max_component(b.extent());
    SSS_CHECK(side > 0.f);
    Vec3 c = b.center();
    for (Vec3& p : mesh.positions) p = (p - c) / side;
    mesh.origin = Vec3d();
}

Vec3d center_of_bounds(const std::vector<Vec3d>& points) {
    Vec3d lo(INFINITY, INFINITY, INFINITY), hi(-INFINITY, -INFINITY, -INFINITY);
    for (const Vec3d& p : points)
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p[a]);
            hi[a] = std::max(hi[a], p[a]);
        }
    return (lo + hi) * 0.5;
}

Vec3d center_of_bounds(const std::vector<Vec3d>& points,
                       const std::vector<std::vector<uint32_t>>& polygons) {
    Vec3d lo(INFINITY, INFINITY, INFINITY), hi(-INFINITY, -INFINITY, -INFINITY);
    for (const auto& poly : polygons)
        for (uint32_t i : poly)
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min(lo[a], points.at(i)[a]);
                hi[a] = std::max(hi[a], points.at(i)[a]);
            }
    return (lo + hi) * 0.5;
}

void check_encloses_volume(const TriangleMesh& mesh, const std::string& what) {
    const double vol = mesh.volume();
    const double scale = double(max_component(mesh.bounds().extent()));
    if (!(vol > 1e-9 * scale * scale * scale))
        fail(what, ": mesh encloses no volume to speak of (flat or degenerate): volume ",
             vol, ", not above 1e-9 L^3 = ", 1e-9 * scale * scale * scale,
             " for the largest side L = ", scale, " of its bounding box");
}

}  // namespace sss

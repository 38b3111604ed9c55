#include "geometry/cut_planes.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/check.h"
#include "core/rng.h"
#include "testing/meshes.h"

using namespace sss;

namespace {

// Points spread over every triangle (its vertices, edge midpoints and random interior
// points): a dense sample of the surface.
std::vector<Vec3> surface_samples(const TriangleMesh& m, int per_triangle, Rng& rng) {
    std::vector<Vec3> out;
    for (const auto& t : m.triangles) {
        const Vec3 a = m.positions[t[0]], b = m.positions[t[1]], c = m.positions[t[2]];
        out.insert(out.end(), {a, b, c, (a + b) * 0.5f, (b + c) * 0.5f, (a + c) * 0.5f});
        for (int k = 0; k < per_triangle; ++k) {
            float u = rng.uniform(), v = rng.uniform();
            if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
            out.push_back(a + (b - a) * u + (c - a) * v);
        }
    }
    return out;
}

}  // namespace

// The certificate's promise: no surface point y with |y - p| <= radius lies below the
// plane, (y - p) . n < s. Checked against a dense sample of the surface at random points
// inside.
TEST(CutPlanes, NoSurfacePointInTheCertifiedRegion) {
    const TriangleMesh mesh = test::lumpy_mesh();
    const DistanceGrid grid = DistanceGrid::build(mesh, 48, 2);
    const float radius = 0.12f;
    const CutPlanes planes = CutPlanes::build(mesh, grid, radius, 2);
    ASSERT_FALSE(planes.empty());
    Rng rng(3);
    const std::vector<Vec3> surface = surface_samples(mesh, 8, rng);
    const Bounds3 b = mesh.bounds();
    std::vector<Vec3> pts;
    while (pts.size() < 4000) {
        const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
        const Vec3 p = b.lo + u * b.extent();
        if (grid.query(p) > 0.f && grid.query(p) < radius) pts.push_back(p);
    }
    const std::vector<bool> inside = points_inside_mesh(mesh, pts);
    int certified = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
        if (!inside[i]) continue;
        Vec3 n;
        float s;
        ASSERT_TRUE(planes.query(pts[i], &n, &s)) << "no certificate near the surface";
        EXPECT_NEAR(length(n), 1.f, 1e-5f);
        ++certified;
        for (const Vec3& y : surface) {
            const Vec3 v = y - pts[i];
            if (dot(v, v) <= radius * radius) {
                ASSERT_GE(dot(v, n), s) << "point " << i;
            }
        }
    }
    EXPECT_GT(certified, 500);
}

// Useful too: on a sphere of radius 1 the plane lies below a point at depth d by at most
// the sagitta over the vertices the certificate looks at (those of triangles within R + c
// of the cell's centre, c a cell diagonal, so within R + c + e, e the longest edge: (R +
// c + e)^2 / 2) and the tessellation's own sagitta (under 1e-3 here).
TEST(CutPlanes, OnASphereThePlaneIsTheTangentPlaneLoweredByTheSagitta) {
    const TriangleMesh sphere = make_icosphere({0, 0, 0}, 1.f, 4);
    const DistanceGrid grid = DistanceGrid::build(sphere, 64, 2);
    const float radius = 0.1f;
    const CutPlanes planes = CutPlanes::build(sphere, grid, radius, 2);
    const float c = std::sqrt(3.f) * grid.cell_size();
    float e = 0.f;
    for (const auto& t : sphere.triangles)
        for (int k = 0; k < 3; ++k)
            e = std::max(
                e, length(sphere.positions[t[k]] - sphere.positions[t[(k + 1) % 3]]));
    const float slack = 0.5f * (radius + c + e) * (radius + c + e) + 1e-3f;
    Rng rng(9);
    for (int i = 0; i < 2000; ++i) {
        Vec3 w(2.f * rng.uniform() - 1.f, 2.f * rng.uniform() - 1.f,
               2.f * rng.uniform() - 1.f);
        if (!(length(w) > 0.1f)) continue;
        const float depth = 0.1f * rng.uniform();
        const Vec3 p = normalize(w) * (1.f - depth);
        Vec3 n;
        float s;
        ASSERT_TRUE(planes.query(p, &n, &s));
        EXPECT_GE(s, depth - slack) << "depth " << depth;
        EXPECT_GT(dot(n, normalize(w)), 0.99f);
    }
}

// On a flat face the bound is exact: a point at depth d below a cube's face, far from its
// edges, gets the face's normal and s = d (up to the guard).
TEST(CutPlanes, ExactOnAFlatFace) {
    const TriangleMesh cube = test::cube_mesh();
    const DistanceGrid grid = DistanceGrid::build(cube, 32, 2);
    const CutPlanes planes = CutPlanes::build(cube, grid, 0.2f, 2);
    for (float d : {0.01f, 0.05f, 0.1f}) {
        Vec3 n;
        float s;
        ASSERT_TRUE(planes.query(Vec3(0.1f, 0.2f, 1.f - d), &n, &s));
        EXPECT_NEAR(n.z, 1.f, 1e-6f);
        EXPECT_NEAR(s, d, 5e-5f);  // the guard
        EXPECT_LE(s, d);
    }
}

TEST(CutPlanes, RefusesABadRadius) {
    const TriangleMesh cube = test::cube_mesh();
    const DistanceGrid grid = DistanceGrid::build(cube, 8, 1);
    EXPECT_THROW(CutPlanes::build(cube, grid, 0.f, 1), Error);
    EXPECT_THROW(CutPlanes::build(cube, grid, NAN, 1), Error);
}

// A floor through the cube: no floor point lies in a certified region either, where a
// certificate built from the cube alone has some.
TEST(CutPlanes, KeepsClearOfObstacles) {
    const TriangleMesh cube = test::cube_mesh(), floor = test::floor_mesh(0.05);
    const float radius = 0.3f;
    const DistanceGrid grid = DistanceGrid::build(cube, 24, 2, 24, {}, floor);
    const CutPlanes with = CutPlanes::build(cube, grid, radius, 2, floor);
    const CutPlanes without =
        CutPlanes::build(cube, DistanceGrid::build(cube, 24, 2), radius, 2);
    Rng rng(5);
    const std::vector<Vec3> surface = surface_samples(floor, 400, rng);
    int certified = 0, crossed_without = 0;
    for (int i = 0; i < 3000; ++i) {
        const Vec3 p(rng.uniform() * 2.f - 1.f, rng.uniform() * 0.6f - 0.25f,
                     rng.uniform() * 2.f - 1.f);
        auto crosses = [&](const CutPlanes& planes) {
            Vec3 n;
            float s;
            if (!planes.query(p, &n, &s)) return false;
            for (const Vec3& y : surface) {
                const Vec3 v = y - p;
                if (dot(v, v) <= radius * radius && dot(v, n) < s) return true;
            }
            return false;
        };
        Vec3 n;
        float s;
        certified += with.query(p, &n, &s);
        ASSERT_FALSE(crosses(with)) << "point " << i;
        crossed_without += crosses(without);
    }
    EXPECT_GT(certified, 100);
    EXPECT_GT(crossed_without, 100);  // the floor matters here
}

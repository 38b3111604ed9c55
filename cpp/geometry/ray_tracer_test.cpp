#include "geometry/ray_tracer.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"
#include "shared/ray_offset.h"
#include "shared/sampling.h"

using namespace sss;

// Rays from random points inside and outside an icosphere in random directions: every hit
// is on the sphere, at the distance along the ray, and reports the hit triangle's
// outward unit normal (the one TriangleMesh::normal gives, counter-clockwise winding).
TEST(RayTracer, HitsReportDistanceTriangleAndOutwardNormal) {
    const TriangleMesh mesh = make_icosphere(Vec3(0.2f, -0.1f, 0.3f), 0.7f, 3);
    RayTracer tracer;
    ASSERT_EQ(tracer.add_mesh(mesh), 0u);
    tracer.commit();
    Rng rng(7, 0, 0);
    int hits = 0, from_inside = 0;
    for (int i = 0; i < 4000; ++i) {
        const Vec3 o =
            Vec3(0.2f, -0.1f, 0.3f) +
            sample_uniform_sphere(rng.uniform(), rng.uniform()) * (1.4f * rng.uniform());
        const Vec3 d = sample_uniform_sphere(rng.uniform(), rng.uniform());
        Hit hit;
        if (!tracer.intersect(o, d, 0.f, 10.f, &hit)) continue;
        ++hits;
        ASSERT_EQ(hit.mesh, 0u);
        ASSERT_LT(hit.prim, mesh.triangles.size());
        const Vec3 n = mesh.normal(hit.prim);
        EXPECT_NEAR(length(hit.normal), 1.f, 1e-5f);
        EXPECT_GT(dot(hit.normal, n), 1.f - 1e-5f) << "ray " << i;
        // The hit point lies in the triangle's plane.
        const Vec3 p = o + d * hit.t;
        EXPECT_NEAR(dot(p - mesh.positions[mesh.triangles[hit.prim][0]], n), 0.f, 1e-5f);
        if (dot(d, hit.normal) > 0.f) ++from_inside;
        // Nothing closer: a segment ending just before the hit crosses nothing.
        Crossing x[4];
        EXPECT_EQ(tracer.crossings(o, d, hit.t * (1.f - 1e-4f), x, 4), 0);
    }
    // Both sides seen: half the origins are inside (all of their rays hit), and about
    // 1 - sqrt(3)/2 of the rays from outside hit.
    EXPECT_GT(from_inside, 1500);
    EXPECT_GT(hits - from_inside, 200);
}

// A closed mesh is watertight to rays through its edges: from points inside, rays aimed
// at random points on every edge (where two triangles meet and a non-watertight test can
// slip between them) all hit it from inside. Embree's robust mode guarantees this;
// without it, 4 % of these rays leak. (Rays aimed exactly at vertices still leak in
// either mode: about 0.3 % of them in robust mode, a case of measure zero in rendering.)
TEST(RayTracer, RaysThroughEdgesDoNotLeakOutOfAClosedMesh) {
    const TriangleMesh mesh = make_icosphere(Vec3(0.f), 1.f, 4);
    RayTracer tracer;
    tracer.add_mesh(mesh);
    tracer.commit();
    Rng rng(11, 0, 0);
    int rays = 0, leaks = 0;
    for (const auto& tri : mesh.triangles)
        for (int e = 0; e < 3; ++e) {
            const Vec3 a = mesh.positions[tri[e]], b = mesh.positions[tri[(e + 1) % 3]];
            const Vec3 q = a + (b - a) * rng.uniform();
            const Vec3 o = sample_uniform_sphere(rng.uniform(), rng.uniform()) *
                           (0.5f * rng.uniform());
            const Vec3 d = normalize(q - o);
            Hit hit;
            ++rays;
            if (!tracer.intersect(o, d, 0.f, 10.f, &hit) || dot(d, hit.normal) <= 0.f)
                ++leaks;
        }
    EXPECT_EQ(leaks, 0) << "of " << rays << " rays";
}

// crossings() lists every triangle a segment crosses, nearest first and each once, the
// same surfaces that successive intersect() calls find one at a time.
TEST(RayTracer, CrossingsAreTheSuccessiveClosestHits) {
    RayTracer tracer;
    const TriangleMesh outer = make_icosphere(Vec3(0.f), 1.f, 3);
    const TriangleMesh inner = make_icosphere(Vec3(0.1f, 0.f, 0.f), 0.4f, 2);
    tracer.add_mesh(outer);
    tracer.add_mesh(inner);
    tracer.commit();
    Rng rng(5, 0, 0);
    int checked = 0;
    for (int i = 0; i < 2000; ++i) {
        const Vec3 o =
            sample_uniform_sphere(rng.uniform(), rng.uniform()) * (1.5f * rng.uniform());
        const Vec3 d = sample_uniform_sphere(rng.uniform(), rng.uniform());
        const float tfar = i % 2 ? 10.f : 0.8f;
        Crossing x[8];
        const int n = tracer.crossings(o, d, tfar, x, 8);
        ASSERT_GE(n, 0);
        // The same surfaces by closest hits, stepping past each one.
        int k = 0;
        float t0 = 0.f;
        for (Hit hit; tracer.intersect(o, d, t0, tfar, &hit);
             t0 = hit.t * (1.f + 1e-5f) + 1e-6f, ++k) {
            ASSERT_LT(k, n) << "ray " << i;
            EXPECT_EQ(x[k].mesh, hit.mesh) << "ray " << i;
            EXPECT_EQ(x[k].prim, hit.prim) << "ray " << i;
            EXPECT_NEAR(x[k].t, hit.t, 1e-5f);
            EXPECT_GT(dot(x[k].normal, hit.normal), 1.f - 1e-5f);
            if (k > 0) {
                EXPECT_LT(x[k - 1].t, x[k].t);
            }
        }
        EXPECT_EQ(k, n) << "ray " << i;
        checked += n;
    }
    EXPECT_GT(checked, 1000);  // 1838 crossings with this seed
    // More crossings than room for: -1.
    Crossing one[1];
    EXPECT_EQ(tracer.crossings(Vec3(-2.f, 0.f, 0.f), Vec3(1.f, 0.f, 0.f), 10.f, one, 1),
              -1);
}

// A ray leaving a surface point from offset_ray_origin never meets that surface again,
// also where the surface's plane is exact in float: an axis-aligned floor through the
// render frame's y = 0 (the hit point's error bound along the normal is 0 there), and the
// same floor moved off 0. Reflected rays in random directions above the floor, and rays
// turned back through it, cross it at most once.
TEST(RayTracer, RaysLeavingAFloorAtZeroDoNotMeetItAgain) {
    for (const float y : {0.f, -0.37f}) {
        TriangleMesh floor;
        floor.positions = {
            {-3.f, y, -3.f}, {3.f, y, -3.f}, {3.f, y, 3.f}, {-3.f, y, 3.f}};
        floor.triangles = {{0, 2, 1}, {0, 3, 2}};
        RayTracer tracer;
        tracer.add_mesh(floor);
        tracer.commit();
        Rng rng(5, 0, 0);
        for (int i = 0; i < 2000; ++i) {
            const Vec3 o(2.f * rng.uniform() - 1.f, y + 1.f, 2.f * rng.uniform() - 1.f);
            const Vec3 d =
                normalize(Vec3(rng.uniform() - 0.5f, -1.f, rng.uniform() - 0.5f));
            Hit hit;
            ASSERT_TRUE(tracer.intersect(o, d, 0.f, 10.f, &hit));
            Vec3 w = sample_uniform_sphere(rng.uniform(), rng.uniform());
            if (w.y < 0.f) w.y = -w.y;  // back up, on the side the ray came from
            Hit again;
            EXPECT_FALSE(
                tracer.intersect(offset_ray_origin(hit.p, hit.p_error, hit.normal, w), w,
                                 0.f, 10.f, &again))
                << "y = " << y << ", ray " << i;
            // Through the floor: the origin is below it, so nothing is met either.
            const Vec3 down(w.x, -w.y, w.z);
            EXPECT_FALSE(
                tracer.intersect(offset_ray_origin(hit.p, hit.p_error, hit.normal, down),
                                 down, 0.f, 10.f, &again));
        }
    }
}

// ray_offset_bounds bounds how far from its triangle's plane a ray leaving a hit starts,
// on meshes far from 0 (large coordinates, large offsets), a long thin one and a floor at
// y = 0 (whose offset falls back to the other axes' error): the media check
// (Scene, near_contact) trusts this bound.
TEST(RayTracer, RayOffsetBoundsHoldForHits) {
    TriangleMesh far_ball = make_icosphere(Vec3(37.f, -12.f, 5.f), 0.75f, 2);
    TriangleMesh sliver = make_icosphere(Vec3(0.f), 1.f, 1);
    for (Vec3& p : sliver.positions) p = Vec3(p.x * 40.f - 300.f, p.y * 0.01f, p.z + 2.f);
    TriangleMesh floor;
    floor.positions = {
        {-3.f, 0.f, -3.f}, {3.f, 0.f, -3.f}, {3.f, 0.f, 3.f}, {-3.f, 0.f, 3.f}};
    floor.triangles = {{0, 2, 1}, {0, 3, 2}};
    for (const TriangleMesh* mesh : {&far_ball, &sliver, &floor}) {
        const std::vector<double> bound = ray_offset_bounds(*mesh);
        RayTracer tracer;
        tracer.add_mesh(*mesh);
        tracer.commit();
        const Bounds3 box = mesh->bounds();
        Rng rng(9, 0, 0);
        int hits = 0;
        for (int i = 0; i < 4000; ++i) {
            // From outside the box towards a random point of it.
            Vec3 target =
                box.lo + box.extent() * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
            Vec3 o = target + sample_uniform_sphere(rng.uniform(), rng.uniform()) *
                                  (length(box.extent()) + 1.f);
            Hit hit;
            if (!tracer.intersect(o, normalize(target - o), 0.f, INFINITY, &hit))
                continue;
            ++hits;
            const auto& t = mesh->triangles[hit.prim];
            const Vec3d v0(mesh->positions[t[0]]);
            const Vec3d e1 = Vec3d(mesh->positions[t[1]]) - v0,
                        e2 = Vec3d(mesh->positions[t[2]]) - v0;
            Vec3d n(e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z,
                    e1.x * e2.y - e1.y * e2.x);
            n = n * (1 / std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z));
            for (int side : {-1, 1}) {
                const Vec3 w = hit.normal * float(side);
                const Vec3d off =
                    Vec3d(offset_ray_origin(hit.p, hit.p_error, hit.normal, w)) - v0;
                const double from_plane =
                    std::abs(off.x * n.x + off.y * n.y + off.z * n.z);
                EXPECT_LE(from_plane, bound[hit.prim]) << "hit " << i;
                EXPECT_GT(from_plane, 0.0);
            }
        }
        EXPECT_GT(hits, 1000);
    }
}

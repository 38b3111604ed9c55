#include "geometry/distance_grid.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>

#include "core/rng.h"
#include "testing/meshes.h"

using namespace sss;

namespace {

struct Stats {
    double worst_excess = 0;  // max over points of r(p) - d(p) and of r(p) - max_query();
                              // must be <= 0
    double worst_loss = 0;    // max over points inside the mesh of d(p) - r(p)
};

Stats check_conservative(const TriangleMesh& mesh, int resolution, int n, uint64_t seed,
                         float* cell = nullptr) {
    DistanceGrid grid = DistanceGrid::build(mesh, resolution, 2);
    Bounds3 b = mesh.bounds();
    Rng rng(seed);
    std::vector<Vec3> pts(n);
    for (Vec3& p : pts) {
        Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
        p = b.lo - b.extent() * 0.1f + u * b.extent() * 1.2f;
    }
    // Also points on grid nodes and on cell planes, where the published grid failed.
    for (int i = 0; i < 200; ++i) {
        Vec3 q = grid.node_position(int(rng.uniform() * grid.nx()),
                                    int(rng.uniform() * grid.ny()),
                                    int(rng.uniform() * grid.nz()));
        pts.push_back(q);
        pts.push_back(q + Vec3(grid.cell_size() * rng.uniform(), 0.f, 0.f));
    }
    // And points within two cells of the surface on both sides, where the bound
    // loses most: on a random triangle, moved along its normal.
    for (int i = 0; i < n / 2; ++i) {
        size_t t = std::min(mesh.triangles.size() - 1,
                            size_t(rng.uniform() * float(mesh.triangles.size())));
        float a = rng.uniform(), c = rng.uniform();
        if (a + c > 1.f) a = 1.f - a, c = 1.f - c;
        const auto& tri = mesh.triangles[t];
        Vec3 y = mesh.positions[tri[0]] * (1.f - a - c) + mesh.positions[tri[1]] * a +
                 mesh.positions[tri[2]] * c;
        pts.push_back(y +
                      mesh.normal(t) * ((rng.uniform() * 4.f - 2.f) * grid.cell_size()));
    }
    std::vector<double> exact = exact_distances(mesh, pts);
    std::vector<bool> inside = points_inside_mesh(mesh, pts);
    if (cell) *cell = grid.cell_size();
    Stats s;
    for (size_t i = 0; i < pts.size(); ++i) {
        double r = grid.query(pts[i]);
        s.worst_excess = std::max(s.worst_excess, r - exact[i]);
        s.worst_excess = std::max(s.worst_excess, r - double(grid.max_query()));
        // Tight where media are; outside, far from the surface, only a valid bound.
        if (inside[i]) s.worst_loss = std::max(s.worst_loss, exact[i] - r);
    }
    return s;
}

}  // namespace

TEST(DistanceGrid, NeverExceedsExactDistanceOnSphere) {
    TriangleMesh m = make_icosphere({0.1f, -0.2f, 0.3f}, 0.7f, 4);
    float h = 0;
    Stats s = check_conservative(m, 32, 20000, 1, &h);
    EXPECT_LE(s.worst_excess, 0.0);
    // As tight as the resolution allows: the nearest corner is at most sqrt(3) h / 2 away
    // and both it and the Lipschitz step lose that much, so d - r <= sqrt(3) h.
    EXPECT_LE(s.worst_loss, std::sqrt(3.0) * h * 1.001) << "cell " << h;
}

TEST(DistanceGrid, NeverExceedsExactDistanceOnLumpyMesh) {
    for (int res : {8, 24, 64}) {
        Stats s = check_conservative(test::lumpy_mesh(), res, 20000, uint64_t(res));
        EXPECT_LE(s.worst_excess, 0.0) << "resolution " << res;
    }
}

// A grid finer than its exact_up_to starts from the coarser one (build's comment): every
// node's side is the exact build's, every distance is a lower bound of the exact
// build's, and the nodes near the surface (inside within the band, outside within a cell
// diagonal) hold the exact build's distances bit for bit. Two levels of refinement.
TEST(DistanceGrid, RefinedGridIsTheExactOneNearTheSurface) {
    const TriangleMesh m = test::lumpy_mesh();
    const int res = 48;
    const DistanceGrid exact = DistanceGrid::build(m, res, 2, res);
    const DistanceGrid fine = DistanceGrid::build(m, res, 2, 12);
    ASSERT_EQ(fine.nx(), exact.nx());
    ASSERT_EQ(fine.ny(), exact.ny());
    ASSERT_EQ(fine.nz(), exact.nz());
    const float coarse_cell = DistanceGrid::build(m, res / 2, 1, 12).cell_size();
    const double deep = DistanceGrid::kRefineBand * std::sqrt(3.0) * coarse_cell;
    const double diagonal = std::sqrt(3.0) * exact.cell_size();
    int near = 0, deeper = 0;
    for (int k = 0; k < exact.nz(); ++k)
        for (int j = 0; j < exact.ny(); ++j)
            for (int i = 0; i < exact.nx(); ++i) {
                const float d = exact.node_distance(i, j, k);
                const bool in = exact.node_inside(i, j, k);
                ASSERT_EQ(fine.node_inside(i, j, k), in) << i << " " << j << " " << k;
                ASSERT_LE(fine.node_distance(i, j, k), d) << i << " " << j << " " << k;
                if (in ? d < deep : d < diagonal) {
                    ASSERT_EQ(fine.node_distance(i, j, k), d)
                        << i << " " << j << " " << k;
                    ++near;
                } else {
                    deeper += in && fine.node_distance(i, j, k) < d;
                }
            }
    EXPECT_GT(near, 1000);
    EXPECT_GT(deeper, 100);  // the deep nodes did keep the coarse bound
}

// The build polls its StopFn once per row of nodes, at every level of refinement and
// from both threads: a stop that turns true partway throws Cancelled without finishing,
// and one that never does leaves the grid as a build without it, node for node.
TEST(DistanceGrid, BuildStopsWhenAskedAndOnlyThen) {
    const TriangleMesh m = test::lumpy_mesh();
    const int res = 48;
    std::atomic<int> polls{0};
    const DistanceGrid plain = DistanceGrid::build(m, res, 2, 12);
    const DistanceGrid watched =
        DistanceGrid::build(m, res, 2, 12, [&] { return ++polls < 0; });
    // every row of the fine grid and of the two coarser ones it is refined from
    int rows = 0;
    for (const int r : {res, res / 2, res / 4}) {
        const DistanceGrid g = DistanceGrid::build(m, r, 1, r);
        rows += g.ny() * g.nz();
    }
    EXPECT_EQ(polls.load(), rows);
    for (int k = 0; k < plain.nz(); ++k)
        for (int j = 0; j < plain.ny(); ++j)
            for (int i = 0; i < plain.nx(); ++i) {
                ASSERT_EQ(watched.node_distance(i, j, k), plain.node_distance(i, j, k));
                ASSERT_EQ(watched.node_inside(i, j, k), plain.node_inside(i, j, k));
            }
    const int all = polls.load();
    for (const int after : {0, 3, all / 2}) {
        std::atomic<int> seen{0};
        EXPECT_THROW(DistanceGrid::build(m, res, 2, 12, [&] { return ++seen > after; }),
                     Cancelled)
            << "stop after " << after << " polls";
        // The threads stop at their next poll: at most one row more each.
        EXPECT_LE(seen.load(), after + 1 + 2) << "stop after " << after << " polls";
    }
}

// query(p, &cell, &bound) is query(p), and bound holds query(q) for every q with
// cell_of(q) == cell (what st relies on to skip a query where no step can happen):
// checked on points drawn near the surface, each with 20 others in its cell; outside the
// grid the cell is -1 and the bound 0.
TEST(DistanceGrid, CellBoundHoldsOverTheCell) {
    const TriangleMesh m = test::lumpy_mesh();
    const DistanceGrid g = DistanceGrid::build(m, 24, 2);
    Rng rng(11);
    const float h = g.cell_size();
    int cells = 0, tight = 0;
    for (int n = 0; n < 2000; ++n) {
        const size_t t = std::min(m.triangles.size() - 1,
                                  size_t(rng.uniform() * float(m.triangles.size())));
        const Vec3 p = m.positions[m.triangles[t][0]] +
                       m.normal(t) * ((rng.uniform() * 4.f - 2.f) * h);
        int64_t cell = -2;
        float bound = -1.f;
        const float r = g.query(p, &cell, &bound);
        ASSERT_EQ(r, g.query(p));
        ASSERT_EQ(cell, g.cell_of(p));
        if (cell < 0) continue;
        ++cells;
        const Vec3 c = (p - g.origin()) / h;
        const Vec3 corner =
            g.origin() + Vec3(std::floor(c.x), std::floor(c.y), std::floor(c.z)) * h;
        float best = 0.f;
        for (int q = 0; q < 20; ++q) {
            const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
            const Vec3 x = corner + u * (0.999f * h);
            if (g.cell_of(x) != cell) continue;
            best = std::max(best, g.query(x));
            ASSERT_LE(g.query(x), bound);
        }
        tight += best > 0.5f * bound;  // a bound, not merely a large number
    }
    EXPECT_GT(cells, 1000);
    EXPECT_GT(tight, cells / 2);
    int64_t cell = 0;
    float bound = 1.f;
    EXPECT_EQ(g.query(Vec3(100.f), &cell, &bound), 0.f);
    EXPECT_EQ(cell, -1);
    EXPECT_EQ(bound, 0.f);
    EXPECT_EQ(g.cell_of(Vec3(100.f)), -1);
}

TEST(DistanceGrid, InsideOutsideAndOutOfGrid) {
    TriangleMesh m = make_icosphere({0, 0, 0}, 1.f, 3);
    DistanceGrid g = DistanceGrid::build(m, 16, 1);
    EXPECT_TRUE(g.inside({0, 0, 0}));
    EXPECT_FALSE(g.inside({1.2f, 0, 0}));
    EXPECT_EQ(g.query({10, 0, 0}), 0.f);  // outside the grid: no information, 0
    EXPECT_GT(g.query({0, 0, 0}), 0.8f);  // true distance ~0.99
    EXPECT_LE(g.query({0, 0, 0}), 1.f);
}

// side() is exact where it answers, and answers for all but the points close to the
// surface (within about a cell): checked against the exact predicate on points drawn
// in the grid's box, many of them near the surface.
TEST(DistanceGrid, SideIsExactWhereItAnswers) {
    for (int res : {8, 32}) {
        const TriangleMesh m = test::lumpy_mesh();
        const DistanceGrid g = DistanceGrid::build(m, res, 1);
        Rng rng(7, uint64_t(res));
        std::vector<Vec3> pts;
        const Bounds3 b = m.bounds();
        for (int i = 0; i < 20000; ++i)
            pts.push_back(b.lo + (b.hi - b.lo) *
                                     Vec3(rng.uniform(), rng.uniform(), rng.uniform()));
        const std::vector<bool> inside = points_inside_mesh(m, pts);
        const std::vector<double> exact = exact_distances(m, pts);
        int answered_far = 0, far = 0;
        for (size_t i = 0; i < pts.size(); ++i) {
            const int side = g.side(pts[i]);
            if (side != 0) {
                EXPECT_EQ(side > 0, bool(inside[i])) << "resolution " << res;
            }
            if (exact[i] > 2.0 * std::sqrt(3.0) * g.cell_size()) {
                ++far;
                answered_far += side != 0;
            }
        }
        EXPECT_EQ(answered_far, far) << "resolution " << res;
    }
}

// Obstacles (opaque surfaces meeting the medium) bound the distances too: a floor through
// the cube is never nearer than the grid says, where the cube's own grid says more; the
// inside flags stay the cube's. Also for a grid refined 3 times (32 cells from 4), whose
// deep nodes keep the coarse bound, which must have seen the floor as well (there a
// node near the floor gets its exact distance where, without the floor, it kept a
// looser coarse one: the grids' bounds are then not ordered, only both valid).
TEST(DistanceGrid, KeepsClearOfObstacles) {
    const TriangleMesh cube = test::cube_mesh(), floor = test::floor_mesh(0.05);
    Rng rng(7);
    std::vector<Vec3> pts(20000);
    for (Vec3& p : pts)
        p = Vec3(rng.uniform() * 2.2f - 1.1f, rng.uniform() * 2.2f - 1.1f,
                 rng.uniform() * 2.2f - 1.1f);
    const std::vector<double> to_cube = exact_distances(cube, pts);
    for (int exact_up_to : {16, 4}) {
        const int res = exact_up_to == 16 ? 16 : 32;
        const DistanceGrid with =
            DistanceGrid::build(cube, res, 2, exact_up_to, {}, floor);
        const DistanceGrid without = DistanceGrid::build(cube, res, 2, exact_up_to);
        int beyond_floor = 0;
        for (size_t i = 0; i < pts.size(); ++i) {
            const Vec3 p = pts[i];
            const float to_floor = std::abs(p.y - 0.05f);
            ASSERT_LE(with.query(p), to_floor)
                << p.x << " " << p.y << " " << p.z << ", resolution " << res;
            ASSERT_LE(with.query(p), to_cube[i]) << ", resolution " << res;
            if (exact_up_to >= res) ASSERT_LE(with.query(p), without.query(p));
            beyond_floor += without.query(p) > to_floor;
        }
        EXPECT_GT(beyond_floor, 1000) << "resolution " << res;
        for (int k = 0; k < with.nz(); ++k)
            for (int j = 0; j < with.ny(); ++j)
                for (int i = 0; i < with.nx(); ++i)
                    ASSERT_EQ(with.node_inside(i, j, k), without.node_inside(i, j, k));
    }
}

// What surface_contact finds: the triangles a floor touches (the cube resting on it, or
// cut by it), none once the cube is lifted, and a surface inside touching nothing.
TEST(SurfaceContact, FindsTouchingTrianglesAndSurfacesInside) {
    const TriangleMesh cube = test::cube_mesh();
    // The bottom face's two triangles and the sides' eight, which meet the floor along
    // their lower edges; not the top's.
    const SurfaceContact resting = surface_contact(cube, test::floor_mesh(-1.0));
    EXPECT_EQ(resting.touching.size(), 10u);
    for (uint32_t t : resting.touching) EXPECT_LT(cube.normal(t).y, 0.5f);
    EXPECT_FALSE(resting.inside);
    const SurfaceContact lifted = surface_contact(cube, test::floor_mesh(-1.0 - 1e-4));
    EXPECT_FALSE(lifted.meets());
    const SurfaceContact through = surface_contact(cube, test::floor_mesh(0.3));
    EXPECT_FALSE(through.inside);            // it touches what it cuts:
    EXPECT_EQ(through.touching.size(), 8u);  // the four sides
    for (uint32_t t : through.touching) EXPECT_NEAR(cube.normal(t).y, 0.f, 1e-6f);
    TriangleMesh wick = test::cube_mesh();
    for (Vec3& p : wick.positions) p = p * 0.1f;
    const SurfaceContact inside = surface_contact(cube, wick);
    EXPECT_TRUE(inside.inside);
    EXPECT_TRUE(inside.touching.empty());
}

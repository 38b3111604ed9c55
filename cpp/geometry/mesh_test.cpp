#include "geometry/mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/check.h"
#include "testing/temp_file.h"

using namespace sss;
using sss::test::TempFile;

namespace {
// A unit cube as OFF text; `flip` reverses the winding of the listed faces.
std::string cube_off(bool flip_some, bool drop_face = false, bool degenerate = false) {
    std::string s = "OFF\n8 " + std::to_string(drop_face ? 11 : 12) + " 0\n";
    s += "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n";
    const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7},
                          {0, 1, 5}, {0, 5, 4}, {2, 3, 7}, {2, 7, 6},
                          {1, 2, 6}, {1, 6, 5}, {0, 4, 7}, {0, 7, 3}};
    for (int i = 0; i < 12; ++i) {
        if (drop_face && i == 11) continue;
        bool flip = flip_some && (i % 3 == 0);
        if (degenerate && i == 2) {
            s += "3 4 5 4\n";
            continue;
        }
        s += flip ? "3 " + std::to_string(f[i][0]) + " " + std::to_string(f[i][2]) + " " +
                        std::to_string(f[i][1]) + "\n"
                  : "3 " + std::to_string(f[i][0]) + " " + std::to_string(f[i][1]) + " " +
                        std::to_string(f[i][2]) + "\n";
    }
    return s;
}

std::string error_of(const std::string& path) {
    try {
        load_mesh(path);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}
}  // namespace

TEST(Mesh, IcosphereIsClosedOutwardAndNearTheSphere) {
    TriangleMesh m = make_icosphere({1, 2, 3}, 2.f, 4);
    EXPECT_EQ(m.triangles.size(), 20u * 256u);
    double v = m.volume(), exact = 4.0 / 3.0 * M_PI * 8.0;
    EXPECT_GT(v, 0.99 * exact);
    EXPECT_LT(v, exact);  // an inscribed polyhedron
    std::vector<std::vector<uint32_t>> polys;
    for (const auto& t : m.triangles) polys.push_back({t[2], t[1], t[0]});  // inside out
    TriangleMesh checked = make_closed_mesh(
        std::vector<Vec3d>(m.positions.begin(), m.positions.end()), polys, "icosphere");
    EXPECT_NEAR(checked.volume(), v, 1e-3 * v);
}

TEST(Mesh, LoadsAndFixesInconsistentOrientation) {
    TempFile f("cube.off", cube_off(/*flip_some=*/true));
    TriangleMesh m = load_mesh(f.path());
    EXPECT_EQ(m.triangles.size(), 12u);
    EXPECT_NEAR(m.volume(), 1.0, 1e-6);  // positive: every face turned outward
}

TEST(Mesh, InsideOutMeshIsTurnedOutward) {
    // Every face reversed: consistent but inside out.
    std::string s = cube_off(false);
    for (size_t pos = 0; (pos = s.find("\n3 ", pos)) != std::string::npos; ++pos) {
        size_t end = s.find('\n', pos + 1);
        int a, b, c;
        std::sscanf(s.c_str() + pos + 3, "%d %d %d", &a, &b, &c);
        s.replace(
            pos + 1, end - pos - 1,
            "3 " + std::to_string(c) + " " + std::to_string(b) + " " + std::to_string(a));
    }
    TriangleMesh m = load_mesh(TempFile("cube.off", s).path());
    EXPECT_NEAR(m.volume(), 1.0, 1e-6);
}

TEST(Mesh, RefusesOpenMesh) {
    TempFile f("open.off", cube_off(false, /*drop_face=*/true));
    EXPECT_NE(error_of(f.path()).find("not closed"), std::string::npos)
        << error_of(f.path());
}

TEST(Mesh, RefusesDegenerateTriangle) {
    TempFile f("degenerate.off", cube_off(false, false, /*degenerate=*/true));
    EXPECT_NE(error_of(f.path()).find("degenerate"), std::string::npos)
        << error_of(f.path());
}

TEST(Mesh, RefusesMissingMalformedAndUnknownFiles) {
    EXPECT_NE(error_of("/nonexistent/bunny.obj").find("does not exist"),
              std::string::npos);
    TempFile bad("bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n");
    EXPECT_NE(error_of(bad.path()).find(bad.path()), std::string::npos);
    TempFile unknown("mesh.xyz", "1 2 3\n");
    EXPECT_NE(error_of(unknown.path()).find("unsupported mesh format"),
              std::string::npos);
    // a directory is said to be one (it was "unsupported mesh format ''")
    const std::string dir = std::filesystem::path(unknown.path()).parent_path().string();
    EXPECT_NE(error_of(dir).find(dir + ": is a directory, not a mesh file"),
              std::string::npos)
        << error_of(dir);
}

TEST(Mesh, ObjQuadsAreTriangulatedAndStlVerticesMerged) {
    std::string obj =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 2 3 7 6\nf 1 5 8 4\n";
    TriangleMesh m = load_mesh(TempFile("cube.obj", obj).path());
    EXPECT_EQ(m.triangles.size(), 12u);
    EXPECT_NEAR(m.volume(), 1.0, 1e-6);

    std::string stl = "solid c\n";
    for (const auto& t : m.triangles) {
        stl += "facet normal 0 0 0\nouter loop\n";
        for (uint32_t i : t) {
            Vec3 p = m.positions[i];
            stl += "vertex " + std::to_string(p.x) + " " + std::to_string(p.y) + " " +
                   std::to_string(p.z) + "\n";
        }
        stl += "endloop\nendfacet\n";
    }
    stl += "endsolid c\n";
    TriangleMesh s = load_mesh(TempFile("cube.stl", stl).path());
    EXPECT_EQ(s.positions.size(), 8u);
    EXPECT_NEAR(s.volume(), 1.0, 1e-6);
}

// OBJ files are read by polygon_readers.cpp: every form of a face's vertex, negative
// indices, continued lines and what a mesh does not need give the same cube; each
// malformed line is named.
TEST(Mesh, ObjFacesInEveryFormReadAsOneCube) {
    const std::string v =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1 1.0\n";
    // A comment's '\' (a Windows path) does not continue it onto the next line (the
    // first vertex's).
    const std::string extras =
        "# a comment\nmtllib cube.mtl\no cube\ng side\ns off\nusemtl wax\nvt 0 0\n"
        "vn 0 0 1\nl 1 2\n# from C:\\models\\\n";
    const std::string f =
        "f 1/1 4/1 3/1 2/1\r\nf 5//1 6//1 7//1 8//1\nf -8/1/1 -7/1/1 -3/1/1 -4/1/1\n"
        "f 3 4 \\\n 8 7  # continued\nfo 2 3 7 6\nf 1 5 8 4\n";
    TriangleMesh m = load_mesh(TempFile("cube.obj", extras + v + f).path());
    EXPECT_EQ(m.triangles.size(), 12u);
    EXPECT_NEAR(m.volume(), 1.0, 1e-6);
    // A byte order mark, superseded keywords and curves beside the polygons: the same.
    const std::string more = "\xEF\xBB\xBFres 4 4\ncstype bspline\ncurv 0 1 1 2\nend\n";
    m = load_mesh(TempFile("more.obj", more + v + f).path());
    EXPECT_EQ(m.triangles.size(), 12u);
    EXPECT_NE(
        error_of(TempFile("curves.obj", "v 0 0 0\ncstype bspline\ncurv 0 1 1 1\n").path())
            .find("free-form geometry (curves, surfaces) and no polygons"),
        std::string::npos);
}

TEST(Mesh, MalformedObjLinesAreNamed) {
    const std::string v =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
    const std::string f = "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\n";
    const struct {
        std::string text, expected;
    } cases[] = {
        {"v 0 0\n" + v + f, "line 1: vertex 1 needs three numbers x y z"},
        {v + "v 1 nan 0\n" + f, "line 9: vertex 9 is not finite"},
        {v + "v 1 1e39 0\n" + f, "line 9: vertex 9 does not fit in single precision"},
        {v + f + "f 3 4 x 7\n", "line 12: vertex index 'x' is not allowed"},
        {v + f + "f 3 4 0 7\n", "line 12: vertex index '0' is not allowed"},
        {v + f + "f 3 4 99999999999999999999 7\n", "line 12: vertex index '9999"},
        {v + f + "f 3 4\n", "line 12: a face needs at least 3 vertices, this one has 2"},
        {v + f + "f 3 4 9 7\n", "line 12: vertex index 9 but the file has 8 vertices"},
        {v + f + "f 3 4 -9 7\n",
         "line 12: vertex index -9 reaches back before the first"},
        {v + "hello world\n" + f, "line 9: unknown keyword 'hello'"},
        {std::string("\x01\x02junk\n") + v + f, "line 1: unknown keyword '??junk'"},
        {v + f + "call more.obj\n", "line 12: 'call' (another file's geometry)"},
        {v + f + "v 1 2 3 4 5 6 7 8\n", "line 12: vertex 9 has 8 numbers"},
    };
    for (const auto& c : cases) {
        TempFile obj("bad.obj", c.text);
        const std::string e = error_of(obj.path());
        EXPECT_NE(e.find(obj.path() + ": malformed OBJ file, " + c.expected),
                  std::string::npos)
            << e << "\nexpected: " << c.expected;
    }
}

TEST(Mesh, TransformAndNormalize) {
    TriangleMesh m = make_icosphere({0, 0, 0}, 1.f, 2);
    Transform t{{-2, 1, 1}, {0, 90, 0}, {5, 0, 0}};
    std::vector<Vec3d> world = transform_mesh(m, t);
    ASSERT_EQ(world.size(), m.positions.size());
    for (size_t i = 0; i < world.size(); ++i) m.positions[i] = world[i].to_float();
    EXPECT_GT(m.volume(), 0.0);  // a mirroring scale keeps the mesh outward
    EXPECT_NEAR(m.bounds().center().x, 5.f, 1e-4f);
    EXPECT_NEAR(m.bounds().extent().z, 4.f, 1e-3f);  // x scaled by 2 then rotated onto z
    normalize_mesh(m);
    EXPECT_NEAR(max_component(m.bounds().extent()), 1.f, 1e-6f);
    EXPECT_NEAR(length(m.bounds().center()), 0.f, 1e-6f);
}

TEST(Mesh, TransformIsExactFarFromTheOrigin) {
    // Double precision: a translation by 1e4 keeps offsets of 1e-6 (float would round
    // them to 1e-3).
    Transform t{{1, 1, 1}, {0, 0, 0}, {1e4, -1e4, 1e4}};
    Vec3d p = t.apply(Vec3d(1e-6, 2e-6, -3e-6));
    EXPECT_NEAR(p.x - 1e4, 1e-6, 1e-11);  // ulp(1e4) in double is 1.8e-12
    EXPECT_NEAR(p.y + 1e4, 2e-6, 1e-11);
    EXPECT_NEAR(p.z - 1e4, -3e-6, 1e-11);
}

TEST(Mesh, AFileFarFromTheOriginKeepsItsShape) {
    // A cube 0.1 wide at 1e6: float coordinates there are 0.0625 apart, which would make
    // it 0.125 wide. The mesh keeps its file's placement in `origin`, in double.
    std::string s = "OFF\n8 12 0\n";
    for (int i = 0; i < 8; ++i)
        for (int a = 0; a < 3; ++a)
            s += std::string((i >> a) & 1 ? "1000000.1" : "1000000") +
                 (a < 2 ? " " : "\n");
    const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6},
                          {0, 1, 4}, {1, 5, 4}, {2, 6, 3}, {3, 6, 7},
                          {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    for (const auto& t : f)
        s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " +
             std::to_string(t[2]) + "\n";
    TriangleMesh m = load_mesh(TempFile("far.off", s).path());
    for (const Vec3d& p : transform_mesh(m, Transform{}))
        for (int a = 0; a < 3; ++a) {
            const double d = p[a] - 1e6;
            EXPECT_TRUE(std::abs(d) < 1e-8 || std::abs(d - 0.1) < 1e-8) << d;
        }
    EXPECT_NEAR(m.volume(), 1e-3, 1e-9);
}

TEST(Mesh, NormalsOfTinyAndHugeTriangles) {
    // A cross product's squared length leaves float's range for edges past ~4e9 or below
    // ~1e-19 (and loses precision below ~1e-10): the normal must still be the unit one.
    for (float s : {1e-20f, 1e-12f, 1.f, 1e12f, 1e18f}) {
        TriangleMesh m;
        m.positions = {{0, 0, 0}, {s, 0, 0}, {0, s, s}};
        m.triangles = {{0, 1, 2}};
        const Vec3 n = m.normal(0);
        EXPECT_NEAR(n.x, 0.f, 1e-6f) << s;
        EXPECT_NEAR(n.y, -0.70710678f, 1e-6f) << s;
        EXPECT_NEAR(n.z, 0.70710678f, 1e-6f) << s;
    }
}

// Everything that includes CGAL: reading polygon soups, checking and orienting closed
// meshes, and exact distances for the distance grid. Kept to one translation unit because
// CGAL is slow to compile. Geometry is handed to CGAL in double precision.
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/intersection.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "core/check.h"
#include "core/files.h"
#include "core/parallel.h"
#include "geometry/cut_planes.h"
#include "geometry/distance_grid.h"
#include "geometry/mesh.h"
#include "geometry/polygon_readers.h"

namespace sss {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Triangle = K::Triangle_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using TriIter = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<K, TriIter>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
namespace PMP = CGAL::Polygon_mesh_processing;

std::vector<Triangle> cgal_triangles(const TriangleMesh& mesh) {
    std::vector<Triangle> tris;
    tris.reserve(mesh.triangles.size());
    auto P = [&](uint32_t i) {
        const Vec3& v = mesh.positions[i];
        return Point(v.x, v.y, v.z);
    };
    for (const auto& t : mesh.triangles) tris.emplace_back(P(t[0]), P(t[1]), P(t[2]));
    return tris;
}

SurfaceMesh to_surface_mesh(const TriangleMesh& mesh) {
    SurfaceMesh sm;
    std::vector<SurfaceMesh::Vertex_index> v;
    v.reserve(mesh.positions.size());
    for (const Vec3& p : mesh.positions) v.push_back(sm.add_vertex(Point(p.x, p.y, p.z)));
    for (const auto& t : mesh.triangles) sm.add_face(v[t[0]], v[t[1]], v[t[2]]);
    return sm;
}

// The triangles of `mesh` and then those of `obstacles` as one mesh (both in the same
// frame): distances and certificates hold for both.
TriangleMesh with_obstacles(const TriangleMesh& mesh, const TriangleMesh& obstacles) {
    TriangleMesh all = mesh;
    append_mesh(all, obstacles, obstacles.bounds());
    return all;
}

// Rounds a non-negative double down to a float (keeps the grid conservative).
Point to_point(Vec3 p) { return Point(p.x, p.y, p.z); }

float round_down(double d) {
    float f = float(d);
    if (double(f) > d) f = std::nextafter(f, 0.f);
    return std::max(f, 0.f);
}

}  // namespace

TriangleMesh load_mesh(const std::string& path, MeshKind kind) {
    namespace fs = std::filesystem;
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    std::error_code ec;  // a directory is said to be one, not a format '' (or '.d')
    if (fs::is_directory(path, ec)) check_input_file(path, "mesh file");
    if (ext != ".obj" && ext != ".ply" && ext != ".off" && ext != ".stl")
        fail(path, ": unsupported mesh format '", ext,
             "' (allowed: .obj, .ply, .off, .stl)");
    check_input_file(path, "mesh file");
    if (!std::ifstream(path).good()) fail(path, ": mesh file cannot be read");

    std::vector<Point> points;
    std::vector<std::vector<std::size_t>> polygons;
    {
        // Our readers (polygon_readers.h): CGAL's crash on malformed PLY and OFF files
        // and do not say where an OBJ or STL file is malformed.
        PolygonSoup soup = ext == ".ply"   ? read_ply(path)
                           : ext == ".off" ? read_off(path)
                           : ext == ".stl" ? read_stl(path)
                                           : read_obj(path);
        for (size_t i = 0; i + 2 < soup.xyz.size(); i += 3)
            points.emplace_back(soup.xyz[i], soup.xyz[i + 1], soup.xyz[i + 2]);
        polygons = std::move(soup.polygons);
    }
    if (points.empty() || polygons.empty()) fail(path, ": mesh has no faces");

    std::vector<Vec3d> pos;
    pos.reserve(points.size());
    for (const Point& p : points) {
        Vec3d v(p.x(), p.y(), p.z());
        if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)))
            fail(path, ": vertex ", pos.size(), " is not finite");
        if (!is_finite(v.to_float()))
            fail(path, ": vertex ", pos.size(), " (", v.x, ", ", v.y, ", ", v.z,
                 ") does not fit in single precision (|x| < 3.4e38)");
        pos.push_back(v);
    }
    std::vector<std::vector<uint32_t>> polys;
    polys.reserve(polygons.size());
    for (const auto& poly : polygons) {
        std::vector<uint32_t> q;
        for (std::size_t i : poly) {
            if (i >= points.size())
                fail(path, ": face ", polys.size(), " uses vertex ", i,
                     " but there are only ", points.size());
            q.push_back(uint32_t(i));
        }
        polys.push_back(std::move(q));
    }
    const Vec3d origin = center_of_bounds(pos, polys);
    return kind == MeshKind::Closed
               ? make_closed_mesh(pos, std::move(polys), path, origin)
               : make_open_mesh(pos, std::move(polys), path, origin);
}

namespace {

// The shortest decimal that reads back as v: vertices 1e-13 apart, which the mesh keeps
// apart, printed alike with six digits.
std::string shortest(double v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

std::string at(const Point& p) {
    return "(" + shortest(p.x()) + ", " + shortest(p.y()) + ", " + shortest(p.z()) + ")";
}

// Ear clipping is O(n^3) at worst: faces with more corners are fanned.
constexpr size_t kMaxEarClippedCorners = 128;

// The triangles of one face (corners `poly`, indices into `pos`), appended to `tris`.
// Corners repeated in a row (f 1 4 3 3, as some exporters write triangles) are one
// corner. A convex face, every corner turning the same way about its Newell normal, is
// fanned from its first corner; any other (a concave n-gon, a corner on a straight edge)
// is ear-clipped in its plane, so that no triangle folds outside the face (a fan from a
// convex corner of an L covered the notch) or has no area where the face has some.
void triangulate_face(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& face,
                      std::vector<std::vector<std::size_t>>& tris) {
    // Most faces: nothing to decide (one of no area is the caller's to name)
    if (face.size() == 3) {
        tris.push_back({face[0], face[1], face[2]});
        return;
    }
    std::vector<uint32_t> poly;
    for (uint32_t i : face)
        if (poly.empty() || length(pos[poly.back()] - pos[i]) > 0.0) poly.push_back(i);
    while (poly.size() > 1 && (poly.back() == poly.front() ||
                               length(pos[poly.back()] - pos[poly.front()]) == 0.0))
        poly.pop_back();
    const size_t m = poly.size();
    if (m < 3) {  // no area: the caller's check names it
        tris.push_back({face[0], face[1], face[2]});
        return;
    }
    // Newell's normal; the face is projected on the plane of the other two axes, in
    // which it turns counter-clockwise where the normal's largest component is positive.
    Vec3d n;
    for (size_t i = 0; i < m; ++i) {
        const Vec3d a = pos[poly[i]], b = pos[poly[(i + 1) % m]];
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    const int ax = std::abs(n.x) >= std::abs(n.y) && std::abs(n.x) >= std::abs(n.z) ? 0
                   : std::abs(n.y) >= std::abs(n.z)                                 ? 1
                                                                                    : 2;
    const int u = (ax + 1) % 3, v = (ax + 2) % 3;
    const double sign = n[ax] >= 0.0 ? 1.0 : -1.0;
    // > 0: a, b, c turn counter-clockwise about the normal
    auto turn = [&](uint32_t a, uint32_t b, uint32_t c) {
        const Vec3d p = pos[a], q = pos[b], r = pos[c];
        return sign * ((q[u] - p[u]) * (r[v] - p[v]) - (q[v] - p[v]) * (r[u] - p[u]));
    };
    bool convex = true;
    for (size_t i = 0; i < m && convex; ++i)
        convex = turn(poly[(i + m - 1) % m], poly[i], poly[(i + 1) % m]) > 0.0;
    std::vector<uint32_t> left = poly;
    if (!convex && m <= kMaxEarClippedCorners) {
        while (left.size() > 3) {
            const size_t k = left.size();
            bool clipped = false;
            for (size_t e = 0; e < k && !clipped; ++e) {
                const uint32_t a = left[(e + k - 1) % k], b = left[e],
                               c = left[(e + 1) % k];
                if (!(turn(a, b, c) > 0.0)) continue;  // reflex or straight: no ear
                bool empty = true;  // no other corner in the ear or on its edges
                for (uint32_t q : left) {
                    if (q == a || q == b || q == c) continue;
                    if (length(pos[q] - pos[a]) == 0.0 || length(pos[q] - pos[c]) == 0.0)
                        continue;  // a corner the face visits twice
                    if (turn(a, b, q) >= 0.0 && turn(b, c, q) >= 0.0 &&
                        turn(c, a, q) >= 0.0) {
                        empty = false;
                        break;
                    }
                }
                if (!empty) continue;
                tris.push_back({a, b, c});
                left.erase(left.begin() + std::ptrdiff_t(e));
                clipped = true;
            }
            if (!clipped) break;  // a face that crosses itself: fanned, as before
        }
    }
    for (size_t i = 1; i + 1 < left.size(); ++i)
        tris.push_back({left[0], left[i], left[i + 1]});
}

// The soup both kinds of mesh start from: polygons triangulated, coincident vertices
// merged, degenerate triangles refused, duplicate triangles and unused vertices dropped.
void clean_soup(const std::vector<Vec3d>& positions,
                const std::vector<std::vector<uint32_t>>& polygons,
                const std::string& what, std::vector<Point>& points,
                std::vector<std::vector<std::size_t>>& tris) {
    // Triangulate polygons (OBJ/PLY/OFF may hold quads or n-gons); face_of: each
    // triangle's face, for messages. A polygon given twice, in either winding, is one
    // face: its two triangulations may differ (a quad and its reverse split along
    // different diagonals), which the merge of duplicate triangles below would not see.
    // (Triangles are left to that merge.)
    struct PositionHash {
        size_t operator()(const std::array<double, 3>& p) const {
            const std::hash<double> h;
            return h(p[0]) ^ (h(p[1]) * 0x9E3779B97F4A7C15ull) ^
                   (h(p[2]) * 0xC2B2AE3D27D4EB4Full);
        }
    };
    std::unordered_map<std::array<double, 3>, uint32_t, PositionHash> first_at;
    std::set<std::vector<uint32_t>> seen;
    std::vector<size_t> face_of;
    for (size_t f = 0; f < polygons.size(); ++f) {
        const auto& poly = polygons[f];
        if (poly.size() < 3)
            fail(what, ": face ", f, " has ", poly.size(),
                 " vertices (at least 3 needed)");
        if (poly.size() > 3) {
            std::vector<uint32_t> key;  // the corners by their positions' first vertex
            for (uint32_t i : poly) {
                const Vec3d p = positions[i];
                key.push_back(first_at.try_emplace({p.x, p.y, p.z}, i).first->second);
            }
            // The cycle from its least vertex, towards its lesser neighbour
            std::rotate(key.begin(), std::min_element(key.begin(), key.end()), key.end());
            if (key.back() < key[1]) std::reverse(key.begin() + 1, key.end());
            if (!seen.insert(key).second) continue;
        }
        triangulate_face(positions, poly, tris);
        face_of.resize(tris.size(), f);
    }
    points.reserve(positions.size());
    for (const Vec3d& p : positions) points.emplace_back(p.x, p.y, p.z);

    // Merge coincident vertices (STL stores every triangle's corners separately).
    PMP::merge_duplicate_points_in_polygon_soup(points, tris);
    for (size_t f = 0; f < tris.size(); ++f) {
        const auto& t = tris[f];
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
            CGAL::collinear(points[t[0]], points[t[1]], points[t[2]])) {
            const auto& face = polygons[face_of[f]];
            std::string corners;
            for (size_t k = 0; k < std::min<size_t>(face.size(), 8); ++k) {
                const Vec3d p = positions[face[k]];
                corners += (k ? ", " : "") + at(Point(p.x, p.y, p.z));
            }
            if (face.size() > 8) corners += ", ...";
            fail(what, ": face ", face_of[f], " (corners ", corners,
                 ") is degenerate: it has a triangle of no area; allowed: faces of "
                 "non-zero area");
        }
    }
    PMP::merge_duplicate_polygons_in_polygon_soup(points, tris);
    // Vertices no face uses (OBJ and PLY may hold them) would be isolated vertices of the
    // surface mesh, which orient_to_bound_a_volume reads out of bounds (found by fuzzing:
    // tests/fuzz/regressions/mesh_obj/unused-vertices).
    PMP::remove_isolated_points_in_polygon_soup(points, tris);
}

// The float position of p relative to origin.
Vec3 relative_to(const Point& p, Vec3d origin) {
    return (Vec3d(p.x(), p.y(), p.z()) - origin).to_float();
}

TriangleMesh soup_to_mesh(const std::vector<Point>& points,
                          const std::vector<std::vector<std::size_t>>& tris,
                          Vec3d origin) {
    TriangleMesh mesh;
    mesh.origin = origin;
    for (const Point& p : points) mesh.positions.push_back(relative_to(p, origin));
    for (const auto& t : tris)
        mesh.triangles.push_back({uint32_t(t[0]), uint32_t(t[1]), uint32_t(t[2])});
    return mesh;
}

}  // namespace

TriangleMesh make_open_mesh(const std::vector<Vec3d>& positions,
                            std::vector<std::vector<uint32_t>> polygons,
                            const std::string& what, Vec3d origin) {
    std::vector<Point> points;
    std::vector<std::vector<std::size_t>> tris;
    clean_soup(positions, polygons, what, points, tris);
    if (tris.empty()) fail(what, ": mesh has no faces");
    return soup_to_mesh(points, tris, origin);
}

namespace {

// What to do about a mesh that is not closed and manifold, said after its defects.
constexpr const char* kRepairAdvice =
    "; repair it with a mesh tool (e.g. MeshLab's Filters > Cleaning and Repairing, or "
    "in Python pymeshfix: MeshFix(v, f).repair()), or make the shape an opaque "
    "'surface', which may be open";

// The edges (vertex pairs, smaller index first) of a triangle soup with the number of
// triangles that share each.
std::map<std::pair<size_t, size_t>, int> edge_counts(
    const std::vector<std::vector<std::size_t>>& tris) {
    std::map<std::pair<size_t, size_t>, int> count;
    for (const auto& t : tris)
        for (int k = 0; k < 3; ++k) {
            const size_t a = t[k], b = t[(k + 1) % 3];
            ++count[{std::min(a, b), std::max(a, b)}];
        }
    return count;
}

// "N edges ..., the first: (x, y, z)-(x, y, z), ...": the edges shared by `wanted`
// triangles (or, wanted < 0, by more than two), up to three of them with coordinates.
std::string list_edges(const std::vector<Point>& points,
                       const std::map<std::pair<size_t, size_t>, int>& count, int wanted,
                       size_t* found) {
    std::string first;
    *found = 0;
    for (const auto& [edge, n] : count) {
        if (wanted >= 0 ? n != wanted : n <= 2) continue;
        if (++*found <= 3)
            first += (*found > 1 ? ", " : "") + at(points[edge.first]) + "-" +
                     at(points[edge.second]) +
                     (wanted < 0 ? " (" + std::to_string(n) + " triangles)" : "");
    }
    return first;
}

// Vertices whose triangles do not form one fan (they join separate sheets): the edges
// opposite a vertex in its triangles fall into more than one connected chain.
std::string list_nonmanifold_vertices(const std::vector<Point>& points,
                                      const std::vector<std::vector<std::size_t>>& tris,
                                      size_t* found) {
    std::vector<std::vector<std::pair<size_t, size_t>>> link(points.size());
    for (const auto& t : tris)
        for (int k = 0; k < 3; ++k)
            link[t[k]].push_back({t[(k + 1) % 3], t[(k + 2) % 3]});
    std::string first;
    *found = 0;
    for (size_t v = 0; v < points.size(); ++v) {
        std::map<size_t, size_t> parent;  // union-find over the link's vertices
        std::function<size_t(size_t)> root = [&](size_t x) {
            while (parent[x] != x) x = parent[x] = parent[parent[x]];
            return x;
        };
        for (const auto& [a, b] : link[v]) {
            parent.emplace(a, a);
            parent.emplace(b, b);
            parent[root(a)] = root(b);
        }
        std::set<size_t> roots;
        for (const auto& entry : parent) roots.insert(root(entry.first));
        if (roots.size() <= 1) continue;
        if (++*found <= 3)
            first += (*found > 1 ? ", " : "") + at(points[v]) + " (" +
                     std::to_string(roots.size()) + " fans)";
    }
    return first;
}

// Why a soup is not a closed 2-manifold, with the first defects by coordinates: edges
// shared by more than two triangles, else edges of one triangle (holes), else vertices
// joining separate sheets. Only on the error path: it maps every edge.
std::string closed_manifold_defects(const std::vector<Point>& points,
                                    const std::vector<std::vector<std::size_t>>& tris) {
    const auto edges = edge_counts(tris);
    size_t found = 0;
    std::ostringstream os;
    const std::string shared = list_edges(points, edges, -1, &found);
    if (found > 0) {
        os << "mesh is not manifold: " << found
           << " edges are shared by more than two triangles, the first: " << shared
           << "; a closed, manifold triangle mesh is required";
        return os.str();
    }
    const std::string open = list_edges(points, edges, 1, &found);
    if (found > 0) {
        os << "mesh is not closed: " << found
           << " edges belong to one triangle only (holes), the first: " << open
           << "; a closed (watertight) triangle mesh is required";
        return os.str();
    }
    const std::string joints = list_nonmanifold_vertices(points, tris, &found);
    if (found == 0)
        return "mesh cannot be oriented consistently (a non-orientable surface); a "
               "closed, orientable triangle mesh is required";
    os << "mesh is not manifold: " << found
       << " vertices join separate sheets of triangles, the first: " << joints
       << "; a closed, manifold triangle mesh is required";
    return os.str();
}

}  // namespace

TriangleMesh make_closed_mesh(const std::vector<Vec3d>& positions,
                              std::vector<std::vector<uint32_t>> polygons,
                              const std::string& what, Vec3d origin) {
    std::vector<Point> points;
    std::vector<std::vector<std::size_t>> tris;
    clean_soup(positions, polygons, what, points, tris);
    const std::vector<std::vector<std::size_t>> unoriented = tris;  // orienting edits it
    const bool oriented = PMP::orient_polygon_soup(points, tris);
    SurfaceMesh sm;
    if (oriented) PMP::polygon_soup_to_polygon_mesh(points, tris, sm);
    if (!oriented || !CGAL::is_closed(sm))
        fail(what, ": ", closed_manifold_defects(points, unoriented), kRepairAdvice);
    PMP::orient_to_bound_a_volume(sm);

    TriangleMesh mesh;
    mesh.origin = origin;
    std::vector<uint32_t> remap(sm.num_vertices());
    for (auto v : sm.vertices()) {
        remap[v.idx()] = uint32_t(mesh.positions.size());
        mesh.positions.push_back(relative_to(sm.point(v), origin));
    }
    for (auto f : sm.faces()) {
        std::array<uint32_t, 3> t{};
        int i = 0;
        for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm))
            t[i++] = remap[v.idx()];
        mesh.triangles.push_back(t);
    }
    check_encloses_volume(mesh, what);
    return mesh;
}

DistanceGrid DistanceGrid::build(const TriangleMesh& mesh, int resolution, int threads,
                                 int exact_up_to, const StopFn& stop,
                                 const TriangleMesh& obstacles) {
    if (resolution < 2 || resolution > 1024)
        fail("distance grid resolution must be in [2, 1024], got ", resolution);
    Bounds3 b = mesh.bounds();
    DistanceGrid grid;
    grid.cell_ = max_component(b.extent()) / float(resolution);
    SSS_CHECK(grid.cell_ > 0.f);
    grid.inv_cell_ = 1.f / grid.cell_;
    grid.origin_ = b.lo - Vec3(grid.cell_);
    for (int a = 0; a < 3; ++a)
        grid.n_[a] = int(std::ceil(b.extent()[a] / grid.cell_)) + 3;
    // Coordinates in the grid are at most this large; float rounding in query() is a few
    // of their ulps (2^-23 relative), with margin.
    const float scale =
        max_component(abs(grid.origin_)) +
        grid.cell_ * float(std::max({grid.n_[0], grid.n_[1], grid.n_[2]}));
    grid.guard_ = 2e-6f * scale;
    size_t count = size_t(grid.n_[0]) * grid.n_[1] * grid.n_[2];
    grid.dist_.resize(count);
    grid.inside_.resize(count);

    std::vector<Triangle> tris = cgal_triangles(with_obstacles(mesh, obstacles));
    Tree tree(tris.begin(), tris.end());
    tree.accelerate_distance_queries();
    // CGAL builds the tree and its search structure lazily, at the first query, behind a
    // check of a plain bool (a data race if the threads make that first query: found by
    // ThreadSanitizer): one query here builds both before the threads share them.
    tree.closest_point(Point(0, 0, 0));
    SurfaceMesh sm = to_surface_mesh(mesh);
    CGAL::Side_of_triangle_mesh<SurfaceMesh, K> side(sm);
    side(Point(0, 0, 0));  // builds its internal tree before the threads share it

    // Every corner of a cell the surface passes through is within a cell diagonal of it.
    // So a node outside the mesh and farther than that from the surface is a corner only
    // of cells wholly outside, where no point of a medium is: any lower bound will do for
    // it, and the diagonal is one. A box query (no triangle within the box around the
    // node) tells these nodes apart far faster than an exact distance, which outside
    // the mesh would be most of the build's time.
    const double diagonal = std::sqrt(3.0) * double(grid.cell_);
    const float far_bound = round_down(diagonal);

    // A fine grid starts from one of half the resolution (see the header): its bound and
    // side() hold at every node, so they settle the nodes deep inside and far outside.
    std::unique_ptr<DistanceGrid> coarse;
    float deep = INFINITY;
    if (resolution > std::max(exact_up_to, 2)) {
        coarse = std::make_unique<DistanceGrid>(
            build(mesh, (resolution + 1) / 2, threads, exact_up_to, stop, obstacles));
        deep = kRefineBand * std::sqrt(3.f) * coarse->cell_size();
    }
    // One slab of nodes (one k) per chunk
    parallel_chunks(threads, grid.n_[2], 1, [&](int64_t k0, int64_t k1) {
        for (int k = int(k0); k < int(k1); ++k) {
            // The closest point of the previous node is the hint for the next: one cell
            // away, it bounds the search tightly from the start (the result is exact
            // either way; 2x faster than the tree's own nearest-point hint).
            Point row_hint = tree.closest_point(to_point(grid.node_position(0, 0, k)));
            for (int j = 0; j < grid.n_[1]; ++j) {
                throw_if_stopped(stop);
                Point hint = row_hint;
                for (int i = 0; i < grid.n_[0]; ++i) {
                    const Point q = to_point(grid.node_position(i, j, k));
                    const size_t idx = grid.index(i, j, k);
                    int known = 0;
                    if (coarse) {
                        const Vec3 x = grid.node_position(i, j, k);
                        known = coarse->side(x);
                        const float r = known != 0 ? coarse->query(x) : 0.f;
                        if (known > 0 && r >= deep) {
                            grid.inside_[idx] = 1;
                            grid.dist_[idx] = r;
                            continue;
                        }
                        if (known < 0 && double(r) >= diagonal) {
                            grid.inside_[idx] = 0;
                            grid.dist_[idx] = far_bound;
                            continue;
                        }
                    }
                    grid.inside_[idx] =
                        known != 0 ? known > 0 : side(q) == CGAL::ON_BOUNDED_SIDE;
                    if (!grid.inside_[idx]) {
                        const K::Iso_cuboid_3 box(q.x() - diagonal, q.y() - diagonal,
                                                  q.z() - diagonal, q.x() + diagonal,
                                                  q.y() + diagonal, q.z() + diagonal);
                        if (!tree.do_intersect(box)) {
                            grid.dist_[idx] = far_bound;
                            continue;
                        }
                    }
                    hint = tree.closest_point(q, hint);
                    if (i == 0) row_hint = hint;
                    grid.dist_[idx] =
                        round_down(std::sqrt(CGAL::squared_distance(q, hint)));
                }
            }
        }
    });
    return grid;
}

CutPlanes CutPlanes::build(const TriangleMesh& medium, const DistanceGrid& grid,
                           float radius, int threads, const TriangleMesh& obstacles) {
    if (!(radius > 0.f) || !std::isfinite(radius))
        fail("cut planes: radius must be a finite number > 0, got ", radius);
    SSS_CHECK(!grid.empty());
    CutPlanes cp;
    cp.cell_ = grid.cell_size();
    cp.inv_cell_ = 1.f / cp.cell_;
    cp.origin_ = grid.origin();
    cp.radius_ = radius;
    cp.n_[0] = grid.nx() - 1, cp.n_[1] = grid.ny() - 1, cp.n_[2] = grid.nz() - 1;
    // Rounding in s(p): p - c and the dot product (a few ulps of the coordinates, which
    // the grid's guard covers) and m's own rounding (down, below).
    cp.guard_ = 4.f * grid.guard() + 1e-6f * radius;
    const double half_diagonal = 0.5 * std::sqrt(3.0) * double(cp.cell_);
    const double reach = double(radius) * (1.0 + 1e-6) + half_diagonal;
    const size_t count = size_t(cp.n_[0]) * cp.n_[1] * cp.n_[2];
    cp.index_.assign(count, -1);

    const TriangleMesh mesh = with_obstacles(medium, obstacles);
    std::vector<Triangle> tris = cgal_triangles(mesh);
    Tree tree(tris.begin(), tris.end());
    tree.accelerate_distance_queries();
    tree.closest_point(Point(0, 0, 0));  // builds the search structure before the threads

    std::vector<std::vector<std::pair<size_t, Entry>>> found(size_t(cp.n_[2]));
    parallel_chunks(threads, cp.n_[2], 1, [&](int64_t k0, int64_t k1) {
        std::vector<Tree::Primitive_id> ids;
        for (int k = int(k0); k < int(k1); ++k) {
            for (int j = 0; j < cp.n_[1]; ++j) {
                for (int i = 0; i < cp.n_[0]; ++i) {
                    bool any_inside = false;
                    float nearest = INFINITY;
                    for (int c = 0; c < 8; ++c) {
                        const int a = i + (c & 1), b = j + ((c >> 1) & 1),
                                  e = k + (c >> 2);
                        any_inside |= grid.node_inside(a, b, e);
                        nearest = std::min(nearest, grid.node_distance(a, b, e));
                    }
                    if (!any_inside || !(double(nearest) < reach + 2.0 * half_diagonal))
                        continue;
                    Entry entry;
                    entry.centre = grid.node_position(i, j, k) + Vec3(0.5f * cp.cell_);
                    const Point c = to_point(entry.centre);
                    const auto [q, id] = tree.closest_point_and_primitive(c);
                    const size_t t = size_t(id - tris.begin());
                    const Vec3 face = mesh.normal(t);
                    const Vec3 to_q(float(q.x() - c.x()), float(q.y() - c.y()),
                                    float(q.z() - c.z()));
                    const float l = length(to_q);
                    // An obstacle's normal may point either way (an open floor's
                    // winding).
                    const bool obstacle = t >= medium.triangles.size();
                    entry.n = (obstacle || dot(to_q, face) > 0.f) && l > 1e-6f * cp.cell_
                                  ? to_q / l
                                  : face;
                    const K::Iso_cuboid_3 box(c.x() - reach, c.y() - reach, c.z() - reach,
                                              c.x() + reach, c.y() + reach,
                                              c.z() + reach);
                    ids.clear();
                    tree.all_intersected_primitives(box, std::back_inserter(ids));
                    double m = reach;
                    for (const auto& t : ids) {
                        // Triangles in the box but not in the ball cannot matter.
                        if (CGAL::squared_distance(c, *t) > reach * reach) continue;
                        for (int v = 0; v < 3; ++v) {
                            const Point& p = t->vertex(v);
                            m = std::min(m, (p.x() - c.x()) * entry.n.x +
                                                (p.y() - c.y()) * entry.n.y +
                                                (p.z() - c.z()) * entry.n.z);
                        }
                    }
                    m = std::max(m, -reach);
                    float mf = float(m);
                    if (double(mf) > m) mf = std::nextafter(mf, -INFINITY);
                    entry.m = mf;
                    found[size_t(k)].emplace_back(
                        (size_t(k) * cp.n_[1] + j) * cp.n_[0] + i, entry);
                }
            }
        }
    });
    for (const auto& slab : found)
        for (const auto& [idx, entry] : slab) {
            cp.index_[idx] = int32_t(cp.entries_.size());
            cp.entries_.push_back(entry);
        }
    return cp;
}

bool point_inside_mesh(const TriangleMesh& mesh, Vec3 p) {
    return points_inside_mesh(mesh, {p})[0];
}

std::vector<bool> points_inside_mesh(const TriangleMesh& mesh,
                                     const std::vector<Vec3>& points) {
    SurfaceMesh sm = to_surface_mesh(mesh);
    CGAL::Side_of_triangle_mesh<SurfaceMesh, K> side(sm);
    std::vector<bool> inside;
    inside.reserve(points.size());
    for (const Vec3& p : points)
        inside.push_back(side(Point(p.x, p.y, p.z)) != CGAL::ON_UNBOUNDED_SIDE);
    return inside;
}

bool meshes_meet(const TriangleMesh& closed, const TriangleMesh& other,
                 bool other_closed) {
    if (!closed.bounds().overlaps(other.bounds())) return false;
    const SurfaceMesh a = to_surface_mesh(closed), b = to_surface_mesh(other);
    if (other_closed)  // surfaces crossing or touching, or one inside the other
        return PMP::do_intersect(
            a, b, CGAL::parameters::do_overlap_test_of_bounded_sides(true),
            CGAL::parameters::do_overlap_test_of_bounded_sides(true));
    if (PMP::do_intersect(a, b)) return true;
    // No contact: `other` lies wholly inside `closed` or wholly outside; one vertex says.
    return CGAL::Side_of_triangle_mesh<SurfaceMesh, K>(a)(to_point(other.positions[0])) !=
           CGAL::ON_UNBOUNDED_SIDE;
}

namespace {

// Whether boxes a and b come within their meshes' offsets' reach (ray_offset_ceiling,
// three times: twice, and a margin for the boxes' own rounding): a test of the boxes
// alone, before any per-triangle work.
bool within_reach(const Bounds3& a, const Bounds3& b) {
    const float reach = float(3 * (ray_offset_ceiling(a) + ray_offset_ceiling(b)));
    Bounds3 grown = a;
    grown.lo = grown.lo - Vec3(reach);
    grown.hi = grown.hi + Vec3(reach);
    return grown.overlaps(b);
}

}  // namespace

namespace {

// Calls f(i, gap, needed) for the pairs of a triangle i of `a` and one of `b` nearer than
// twice the sum of their offset bounds (`needed`: a margin of 2 on the bound), the
// triangles of `a` in order, until f returns true for i (then on with i + 1).
template <class F>
void near_pairs(const TriangleMesh& a, const TriangleMesh& b, F f) {
    const std::vector<double> off_a = ray_offset_bounds(a), off_b = ray_offset_bounds(b);
    const double most_b = *std::max_element(off_b.begin(), off_b.end());
    std::vector<Triangle> ta = cgal_triangles(a), tb = cgal_triangles(b);
    CGAL::Bbox_3 box_b;
    for (const Triangle& t : tb) box_b += t.bbox();
    Tree tree(tb.begin(), tb.end());
    std::vector<Primitive::Id> near;
    for (size_t i = 0; i < ta.size(); ++i) {
        const double by = 2 * (off_a[i] + most_b);
        const CGAL::Bbox_3 t = ta[i].bbox();
        const CGAL::Bbox_3 query(t.xmin() - by, t.ymin() - by, t.zmin() - by,
                                 t.xmax() + by, t.ymax() + by, t.zmax() + by);
        if (!CGAL::do_overlap(query, box_b)) continue;
        near.clear();
        tree.all_intersected_primitives(query, std::back_inserter(near));
        for (TriIter u : near) {
            const double needed = 2 * (off_a[i] + off_b[size_t(u - tb.begin())]);
            const double gap = std::sqrt(CGAL::squared_distance(ta[i], *u));
            if (gap < needed && f(i, gap, needed)) break;
        }
    }
}

}  // namespace

NearContact near_contact(const TriangleMesh& a, const TriangleMesh& b) {
    NearContact worst;
    if (!within_reach(a.bounds(), b.bounds())) return worst;
    near_pairs(a, b, [&](size_t, double gap, double needed) {
        if (needed - gap > worst.needed - worst.gap) worst = {gap, needed};
        return false;
    });
    return worst;
}

SurfaceContact surface_contact(const TriangleMesh& medium, const TriangleMesh& surface) {
    SurfaceContact contact;
    const Bounds3 box_m = medium.bounds();
    if (!within_reach(box_m, surface.bounds())) return contact;
    // Touching: a surface triangle within twice the two offsets of a medium triangle,
    // where a ray may hit either first.
    near_pairs(medium, surface, [&](size_t i, double, double) {
        contact.touching.push_back(uint32_t(i));
        return true;
    });

    // Inside, touching nothing (a wick in a candle): a corner of the surface inside the
    // medium. (A surface through the medium's surface touches the triangles it crosses.)
    const bool corner_in_box =
        std::any_of(surface.positions.begin(), surface.positions.end(),
                    [&](const Vec3& p) { return box_m.contains(p); });
    if (contact.touching.empty() && corner_in_box) {
        const SurfaceMesh sm = to_surface_mesh(medium);
        CGAL::Side_of_triangle_mesh<SurfaceMesh, K> side(sm);
        contact.inside = std::any_of(
            surface.positions.begin(), surface.positions.end(), [&](const Vec3& p) {
                return box_m.contains(p) && side(to_point(p)) == CGAL::ON_BOUNDED_SIDE;
            });
    }
    return contact;
}

std::vector<double> exact_distances(const TriangleMesh& mesh,
                                    const std::vector<Vec3>& points) {
    std::vector<Triangle> tris = cgal_triangles(mesh);
    Tree tree(tris.begin(), tris.end());
    tree.accelerate_distance_queries();
    std::vector<double> d;
    d.reserve(points.size());
    for (const Vec3& p : points)
        d.push_back(std::sqrt(tree.squared_distance(Point(p.x, p.y, p.z))));
    return d;
}

}  // namespace sss

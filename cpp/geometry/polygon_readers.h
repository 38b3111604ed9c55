// Readers for the PLY and OFF polygon formats. CGAL's readers for these two crash on
// malformed files (found by fuzzing: tests/fuzz/regressions/mesh_ply, mesh_off), so
// load_mesh uses these instead; OBJ and STL still go through CGAL. Both read a polygon
// soup and check everything they read: malformed input throws sss::Error naming the file,
// the line or element, and what is allowed.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace sss {

struct PolygonSoup {
    std::vector<double> xyz;                         // 3 per vertex
    std::vector<std::vector<std::size_t>> polygons;  // vertex indices per face
};

// PLY, ASCII or binary (either byte order): the "vertex" element's x, y, z and the "face"
// element's vertex_indices (or vertex_index) list; other elements and properties are read
// and ignored.
PolygonSoup read_ply(const std::string& path);

// OFF in ASCII (also COFF, NOFF, CNOFF, STOFF ...: colours, normals and texture
// coordinates after a vertex's x, y, z or a face's indices are ignored).
PolygonSoup read_off(const std::string& path);

}  // namespace sss

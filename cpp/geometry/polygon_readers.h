// Readers for the PLY, OFF, OBJ and STL polygon formats. CGAL's readers for PLY and OFF
// crash on malformed files (found by fuzzing: tests/fuzz/regressions/mesh_ply, mesh_off),
// its OBJ reader says only "malformed" (or reads "f 1 2 x" as a face of two vertices) and
// its STL reader only "malformed" (no line for a truncated ASCII file), so load_mesh uses
// these instead. Each reads a polygon soup and checks everything it reads: malformed
// input throws sss::Error naming the file, the line or element, and what is allowed.
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

// OBJ: 'v' lines (x y z; a w or colours after them are ignored) and 'f' lines (indices
// v, v/vt, v/vt/vn or v//vn, counted from 1, or back from the last vertex read when
// negative), joined across a trailing '\'. Texture coordinates, normals, groups,
// materials, lines and free-form geometry (curves, surfaces) are read and ignored; a file
// of free-form geometry only, 'call' and unknown keywords are refused. A byte order mark
// is skipped.
PolygonSoup read_obj(const std::string& path);

// STL, binary (when the file's size is the one its triangle count gives) or ASCII (one or
// more "solid ... endsolid" blocks; keywords in any case; a facet may have more than 3
// vertices). Each facet's corners are vertices of their own: load_mesh merges them.
PolygonSoup read_stl(const std::string& path);

}  // namespace sss

// A bounding-volume hierarchy over the triangles of several meshes, flattened into plain
// arrays for the GPU path (cpp/gpu/shaders/scene.glsl traverses it). Embree's BVH builder
// (rtcBuildBVH, binned SAH) chooses the splits; this file only lays the tree out.
//
// Layout (std430-compatible, 64 bytes per node and per triangle):
//   node: the bounds of both children and a reference to each. A reference is the index
//         of an inner node, or (bit 31 set) a leaf: its first triangle in bits 0..26 and
//         its count - 1 in bits 27..30; kNoChild marks an absent second child.
//   triangle: its corners v0, v1, v2 as stored in the mesh (neighbours share their edges'
//         floats exactly, which the shader's watertight test needs), the outward unit
//         normal (CCW winding), the mesh index and the triangle's index within its mesh.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.h"

namespace sss {

struct FlatBvhNode {
    float lo0[3], hi0[3];  // child 0's box
    float lo1[3], hi1[3];  // child 1's box
    uint32_t child[2];     // references (see above)
    uint32_t pad[2] = {0, 0};
};
static_assert(sizeof(FlatBvhNode) == 64);

struct FlatTriangle {
    float v0[3];
    uint32_t mesh;
    float v1[3];
    uint32_t prim;
    float v2[3];
    float pad0 = 0.f;
    float n[3];
    float touching = 0.f;  // 1: Scene::touches_surface (set by the GPU scene's bake)
};
static_assert(sizeof(FlatTriangle) == 64);

constexpr uint32_t kBvhLeafBit = 0x80000000u;
constexpr uint32_t kBvhNoChild = 0xffffffffu;
constexpr int kBvhMaxLeafSize = 8;  // fits the 4-bit count field
constexpr int kBvhMaxDepth = 48;    // the shader's traversal stack holds this many nodes

struct FlatBvh {
    std::vector<FlatBvhNode> nodes;  // nodes[0] is the root
    std::vector<FlatTriangle> triangles;
};

// Mesh i of `meshes` gets index i in FlatTriangle::mesh (the order RayTracer::add_mesh
// gives). At least one triangle in all.
FlatBvh build_flat_bvh(const std::vector<const TriangleMesh*>& meshes);

}  // namespace sss

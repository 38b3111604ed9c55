#include "geometry/flat_bvh.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <functional>

#include "core/check.h"

namespace sss {

namespace {

// The tree as Embree's builder hands it over (allocated in its thread-local arenas,
// freed with the RTCBVH).
struct BuildNode {
    bool leaf = false;
    // Inner node:
    BuildNode* child[2] = {nullptr, nullptr};
    RTCBounds bounds[2];
    unsigned count = 0;  // children
    // Leaf:
    const RTCBuildPrimitive* prims = nullptr;  // copied below: Embree reuses the array
    uint32_t prim_ids[kBvhMaxLeafSize];
    size_t num_prims = 0;
};

void* create_node(RTCThreadLocalAllocator alloc, unsigned count, void*) {
    SSS_CHECK(count <= 2);
    void* mem = rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16);
    auto* n = new (mem) BuildNode();
    n->count = count;
    return n;
}

void set_children(void* node, void** children, unsigned count, void*) {
    auto* n = static_cast<BuildNode*>(node);
    for (unsigned i = 0; i < count; ++i)
        n->child[i] = static_cast<BuildNode*>(children[i]);
}

void set_bounds(void* node, const RTCBounds** bounds, unsigned count, void*) {
    auto* n = static_cast<BuildNode*>(node);
    for (unsigned i = 0; i < count; ++i) n->bounds[i] = *bounds[i];
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims,
                  size_t count, void*) {
    SSS_CHECK(count >= 1 && count <= size_t(kBvhMaxLeafSize));
    void* mem = rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16);
    auto* n = new (mem) BuildNode();
    n->leaf = true;
    n->num_prims = count;
    for (size_t i = 0; i < count; ++i) n->prim_ids[i] = prims[i].primID;
    return n;
}

void set_box(float* lo, float* hi, const RTCBounds& b) {
    lo[0] = b.lower_x, lo[1] = b.lower_y, lo[2] = b.lower_z;
    hi[0] = b.upper_x, hi[1] = b.upper_y, hi[2] = b.upper_z;
}

}  // namespace

FlatBvh build_flat_bvh(const std::vector<const TriangleMesh*>& meshes) {
    // Every triangle of every mesh, in order; primID indexes this list.
    std::vector<FlatTriangle> all;
    std::vector<RTCBuildPrimitive> prims;
    for (size_t m = 0; m < meshes.size(); ++m) {
        const TriangleMesh& mesh = *meshes[m];
        for (size_t i = 0; i < mesh.triangles.size(); ++i) {
            const auto& tri = mesh.triangles[i];
            const Vec3 a = mesh.positions[tri[0]], b = mesh.positions[tri[1]],
                       c = mesh.positions[tri[2]];
            FlatTriangle t;
            const Vec3 n = mesh.normal(i);
            for (int k = 0; k < 3; ++k)
                t.v0[k] = a[k], t.v1[k] = b[k], t.v2[k] = c[k], t.n[k] = n[k];
            t.mesh = uint32_t(m);
            t.prim = uint32_t(i);
            all.push_back(t);
            const Vec3 lo = min(min(a, b), c), hi = max(max(a, b), c);
            RTCBuildPrimitive p;
            p.lower_x = lo.x, p.lower_y = lo.y, p.lower_z = lo.z;
            p.upper_x = hi.x, p.upper_y = hi.y, p.upper_z = hi.z;
            p.geomID = 0;
            p.primID = unsigned(all.size() - 1);
            prims.push_back(p);
        }
    }
    if (all.empty()) fail("build_flat_bvh: the scene has no triangles");
    if (all.size() >= (size_t(1) << 27))
        fail("build_flat_bvh: ", all.size(),
             " triangles are more than the GPU path supports (2^27)");

    RTCDevice device = rtcNewDevice(nullptr);
    if (!device)
        fail("cannot create an Embree device (error ", int(rtcGetDeviceError(nullptr)),
             ")");
    RTCBVH bvh = rtcNewBVH(device);
    RTCBuildArguments args = rtcDefaultBuildArguments();
    args.byteSize = sizeof(args);
    args.buildQuality = RTC_BUILD_QUALITY_HIGH;
    args.maxBranchingFactor = 2;
    args.maxDepth = kBvhMaxDepth - 1;
    args.minLeafSize = 1;
    args.maxLeafSize = kBvhMaxLeafSize;
    args.traversalCost = 1.f;
    args.intersectionCost = 1.f;
    args.bvh = bvh;
    args.primitives = prims.data();
    args.primitiveCount = prims.size();
    args.primitiveArrayCapacity = prims.size();
    args.createNode = create_node;
    args.setNodeChildren = set_children;
    args.setNodeBounds = set_bounds;
    args.createLeaf = create_leaf;
    const auto* root = static_cast<const BuildNode*>(rtcBuildBVH(&args));
    if (!root) {
        rtcReleaseBVH(bvh);
        rtcReleaseDevice(device);
        fail("Embree's BVH builder failed (error ", int(rtcGetDeviceError(device)), ")");
    }

    // Depth first: an inner node's index is taken before its children are laid out.
    FlatBvh out;
    std::function<uint32_t(const BuildNode*)> lay_out = [&](const BuildNode* n) {
        if (n->leaf) {
            const uint32_t first = uint32_t(out.triangles.size());
            for (size_t i = 0; i < n->num_prims; ++i)
                out.triangles.push_back(all[n->prim_ids[i]]);
            return kBvhLeafBit | (uint32_t(n->num_prims - 1) << 27) | first;
        }
        const uint32_t index = uint32_t(out.nodes.size());
        out.nodes.emplace_back();
        for (unsigned c = 0; c < 2; ++c) {
            uint32_t ref = kBvhNoChild;
            RTCBounds b{};
            if (c < n->count) {
                ref = lay_out(n->child[c]);
                b = n->bounds[c];
            } else {  // an empty box no ray meets
                b.lower_x = b.lower_y = b.lower_z = 1.f;
                b.upper_x = b.upper_y = b.upper_z = -1.f;
            }
            FlatBvhNode& node = out.nodes[index];
            node.child[c] = ref;
            set_box(c == 0 ? node.lo0 : node.lo1, c == 0 ? node.hi0 : node.hi1, b);
        }
        return index;
    };
    if (root->leaf) {
        // A tree of one leaf: a root with that leaf as its only child.
        BuildNode wrapper;
        wrapper.count = 1;
        wrapper.child[0] = const_cast<BuildNode*>(root);
        RTCBounds b{1e30f, 1e30f, 1e30f, 0.f, -1e30f, -1e30f, -1e30f, 0.f};
        for (size_t i = 0; i < root->num_prims; ++i) {
            const RTCBuildPrimitive& p = prims[root->prim_ids[i]];
            b.lower_x = std::min(b.lower_x, p.lower_x);
            b.lower_y = std::min(b.lower_y, p.lower_y);
            b.lower_z = std::min(b.lower_z, p.lower_z);
            b.upper_x = std::max(b.upper_x, p.upper_x);
            b.upper_y = std::max(b.upper_y, p.upper_y);
            b.upper_z = std::max(b.upper_z, p.upper_z);
        }
        wrapper.bounds[0] = b;
        lay_out(&wrapper);
    } else {
        lay_out(root);
    }
    rtcReleaseBVH(bvh);
    rtcReleaseDevice(device);
    return out;
}

}  // namespace sss

#include "geometry/ray_tracer.h"

#include <embree3/rtcore.h>

#include <cmath>
#include <utility>

#include "core/check.h"
#include "shared/ray_offset.h"

namespace sss {

namespace {
void embree_error(void*, RTCError code, const char* message) {
    // Registered once on the device; Embree calls it from whichever thread failed.
    fail("Embree error ", int(code), ": ", message ? message : "(no message)");
}

// The segment o + t d, t in (tnear, tfar), with no hit yet.
RTCRayHit embree_ray(const Vec3& o, const Vec3& d, float tnear, float tfar) {
    RTCRayHit rh;
    rh.ray.org_x = o.x;
    rh.ray.org_y = o.y;
    rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x;
    rh.ray.dir_y = d.y;
    rh.ray.dir_z = d.z;
    rh.ray.tnear = tnear;
    rh.ray.tfar = tfar;
    rh.ray.time = 0.f;
    rh.ray.mask = 0xffffffffu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

// The intersect context of crossings(): Embree hands the filter a pointer to `rtc`, the
// first member, and so to the whole struct.
struct CrossingContext {
    RTCIntersectContext rtc;
    Crossing* out;
    int max;
    int count;  // -1 once more than max were found
};

// Records every hit and rejects it, so that the traversal goes on to the next one.
void record_crossing(const RTCFilterFunctionNArguments* args) {
    auto* c = reinterpret_cast<CrossingContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (!args->valid[i]) continue;
        args->valid[i] = 0;
        if (c->count < 0) continue;
        const unsigned mesh = RTCHitN_geomID(args->hit, args->N, i);
        const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
        // The same triangle again: Embree may reference a triangle from several leaves
        // (spatial splits of the high-quality build). Not seen on our meshes; kept as a
        // guard, it costs a scan of the few crossings so far.
        bool seen = false;
        for (int k = 0; k < c->count && !seen; ++k)
            seen = c->out[k].mesh == mesh && c->out[k].prim == prim;
        if (seen) continue;
        if (c->count == c->max) {
            c->count = -1;
            continue;
        }
        Crossing& x = c->out[c->count++];
        x.t = RTCRayN_tfar(args->ray, args->N, i);
        x.mesh = mesh;
        x.prim = prim;
        x.normal = unit_normal(Vec3(RTCHitN_Ng_x(args->hit, args->N, i),
                                    RTCHitN_Ng_y(args->hit, args->N, i),
                                    RTCHitN_Ng_z(args->hit, args->N, i)));
    }
}

// The intersect context of intersect_skipping(), as CrossingContext.
struct SkipContext {
    RTCIntersectContext rtc;
    unsigned skip;
};

// Rejects the hits on the skipped mesh.
void skip_mesh(const RTCFilterFunctionNArguments* args) {
    const unsigned skip = reinterpret_cast<const SkipContext*>(args->context)->skip;
    for (unsigned i = 0; i < args->N; ++i)
        if (args->valid[i] && RTCHitN_geomID(args->hit, args->N, i) == skip)
            args->valid[i] = 0;
}
}  // namespace

struct RayTracer::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    unsigned num_meshes = 0;
    bool committed = false;
    // Each mesh's vertex and index buffers (owned by its Embree geometry, which the scene
    // holds): hit points are rebuilt from them.
    std::vector<const float*> vertices;
    std::vector<const unsigned*> indices;
};

RayTracer::RayTracer() : impl_(std::make_unique<Impl>()) {
    impl_->device = rtcNewDevice(nullptr);
    if (!impl_->device)
        fail("cannot create an Embree device (error ", int(rtcGetDeviceError(nullptr)),
             ")");
    rtcSetDeviceErrorFunction(impl_->device, embree_error, nullptr);
    impl_->scene = rtcNewScene(impl_->device);
    // Robust traversal: watertight hits on shared edges, so no ray leaks through a closed
    // mesh.
    // Context filters: crossings() collects every hit of one ray, intersect_skipping()
    // passes through one mesh.
    rtcSetSceneFlags(impl_->scene,
                     RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
}

RayTracer::~RayTracer() {
    if (impl_->scene) rtcReleaseScene(impl_->scene);
    if (impl_->device) rtcReleaseDevice(impl_->device);
}

unsigned RayTracer::add_mesh(const TriangleMesh& mesh) {
    SSS_CHECK(!impl_->committed);
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), mesh.positions.size()));
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
        v[3 * i] = mesh.positions[i].x;
        v[3 * i + 1] = mesh.positions[i].y;
        v[3 * i + 2] = mesh.positions[i].z;
    }
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), mesh.triangles.size()));
    for (size_t i = 0; i < mesh.triangles.size(); ++i)
        for (int c = 0; c < 3; ++c) idx[3 * i + c] = mesh.triangles[i][c];
    rtcCommitGeometry(geom);
    impl_->vertices.push_back(v);
    impl_->indices.push_back(idx);
    unsigned id = rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);  // the scene holds the reference now
    SSS_CHECK(id == impl_->num_meshes++);
    return id;
}

void RayTracer::commit() {
    rtcCommitScene(impl_->scene);
    impl_->committed = true;
}

bool RayTracer::intersect(const Vec3& o, const Vec3& d, float tnear, float tfar,
                          Hit* hit) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    return closest(o, d, tnear, tfar, &ctx, hit);
}

bool RayTracer::intersect_skipping(const Vec3& o, const Vec3& d, float tnear, float tfar,
                                   unsigned skip, Hit* hit) const {
    SkipContext c;
    rtcInitIntersectContext(&c.rtc);
    c.rtc.filter = skip_mesh;
    c.skip = skip;
    return closest(o, d, tnear, tfar, &c.rtc, hit);
}

bool RayTracer::closest(const Vec3& o, const Vec3& d, float tnear, float tfar,
                        void* context, Hit* hit) const {
    RTCRayHit rh = embree_ray(o, d, tnear, tfar);
    rtcIntersect1(impl_->scene, static_cast<RTCIntersectContext*>(context), &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    hit->t = rh.ray.tfar;
    hit->mesh = rh.hit.geomID;
    hit->prim = rh.hit.primID;
    // Embree's geometric normal, computed from the triangle it has just loaded (a table
    // of our own normals cost a cache miss per hit: 5 % of the time at sigma_t = 10).
    // Unnormalized, it points the way TriangleMesh::normal does (ray_tracer_test checks).
    hit->normal = unit_normal(Vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
    // The point from the triangle itself: its error bound follows the triangle's
    // coordinates, not the ray's origin (a camera 1000 radii away would put it 1000x
    // further off).
    const unsigned* tri = impl_->indices[hit->mesh] + 3 * size_t(hit->prim);
    const float* v = impl_->vertices[hit->mesh];
    const Vec3 v0(v[3 * tri[0]], v[3 * tri[0] + 1], v[3 * tri[0] + 2]);
    const Vec3 v1(v[3 * tri[1]], v[3 * tri[1] + 1], v[3 * tri[1] + 2]);
    const Vec3 v2(v[3 * tri[2]], v[3 * tri[2] + 1], v[3 * tri[2] + 2]);
    hit->p = triangle_point(v0, v1 - v0, v2 - v0, rh.hit.u, rh.hit.v, hit->p_error);
    return true;
}

int RayTracer::crossings(const Vec3& o, const Vec3& d, float tfar, Crossing* out,
                         int max) const {
    CrossingContext c;
    rtcInitIntersectContext(&c.rtc);
    c.rtc.filter = record_crossing;
    c.out = out;
    c.max = max;
    c.count = 0;
    RTCRayHit rh = embree_ray(o, d, 0.f, tfar);
    rtcIntersect1(impl_->scene, &c.rtc, &rh);
    // Few crossings: insertion sort by distance.
    for (int i = 1; i < c.count; ++i)
        for (int k = i; k > 0 && out[k].t < out[k - 1].t; --k)
            std::swap(out[k], out[k - 1]);
    return c.count;
}

}  // namespace sss

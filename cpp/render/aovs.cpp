#include "render/aovs.h"

#include "core/check.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "geometry/ray_tracer.h"
#include "render/camera.h"
#include "render/medium_presets.h"

namespace sss {

Vec3 medium_aov_albedo(const Medium& medium) {
    const float g = medium.phase.kind().mean_cosine(medium.phase);
    Vec3 a;
    for (int c = 0; c < 3; ++c) {
        const float sigma_s_prime = medium.albedo[c] * medium.sigma_t[c] * (1.f - g);
        const float sigma_a = (1.f - medium.albedo[c]) * medium.sigma_t[c];
        const float total = sigma_s_prime + sigma_a;
        a[c] = total > 0.f ? multiple_scattering_albedo(sigma_s_prime / total) : 0.f;
    }
    return a;
}

FirstHitAovs first_hit_aovs(const Scene& scene, uint64_t seed, int samples, int threads,
                            const StopFn& stop) {
    SSS_CHECK(samples >= 1);
    const Camera& cam = scene.desc().camera;
    const PinholeCamera camera(cam);
    FirstHitAovs aovs;
    aovs.width = cam.width;
    aovs.height = cam.height;
    aovs.samples = samples;
    const size_t pixels = size_t(cam.width) * cam.height;
    aovs.albedo.assign(3 * pixels, 0.f);
    aovs.normal.assign(3 * pixels, 0.f);
    aovs.depth.assign(pixels, 0.f);
    aovs.shape.assign(pixels, -1);

    std::vector<Vec3> shape_albedo;
    for (const Shape& s : scene.desc().shapes)
        shape_albedo.push_back(s.is_surface() ? s.surface.color
                                              : medium_aov_albedo(s.medium));

    const float inv = 1.f / float(samples);
    const float start = scene.camera_ray_start();
    parallel_chunks(threads, int64_t(pixels), 256, [&](int64_t begin, int64_t end) {
        for (int64_t p = begin; p < end; ++p) {
            const int x = int(p % cam.width), y = int(p / cam.width);
            Vec3 albedo(0.f), normal(0.f);
            float depth = 0.f;
            for (int s = 0; s < samples; ++s) {
                if (s % 4096 == 0) throw_if_stopped(stop);
                // The render's camera ray of sample s (integrators/integrator.cpp), from
                // where it starts, and what it meets first: the surface lying on a
                // medium's face where it hits the face (Scene::surface_at, as the
                // render).
                Rng rng(seed, uint64_t(p), uint64_t(s));
                const float jx = rng.uniform(), jy = rng.uniform();
                const Vec3 d = camera.direction(x + jx, y + jy);
                const Vec3 o = camera.origin() + d * start;
                Hit hit;
                if (!scene.tracer().intersect(o, d, 0.f, kInf, &hit)) continue;
                if (Hit on; scene.surface_at(o, d, hit, &on)) hit = on;
                const int shape = int(hit.mesh) < scene.num_shapes() ? int(hit.mesh) : -1;
                if (s == 0) aovs.shape[p] = shape;
                albedo += shape >= 0 ? shape_albedo[shape] : Vec3(1.f);
                normal += dot(hit.normal, d) > 0.f ? -hit.normal : hit.normal;
                depth += start + hit.t;
            }
            for (int c = 0; c < 3; ++c) {
                aovs.albedo[3 * p + c] = albedo[c] * inv;
                aovs.normal[3 * p + c] = normal[c] * inv;
            }
            aovs.depth[p] = depth * inv;
        }
    });
    return aovs;
}

}  // namespace sss

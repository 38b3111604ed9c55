// Small scenes built in code for the C++ tests of render/.
#pragma once

#include "geometry/mesh.h"
#include "render/scene.h"

namespace sss::test {

// A unit sphere of the given medium and boundary in a constant environment of radiance 1,
// seen by a 16x16 camera (the white furnace when albedo = 1); optionally a point light.
inline SceneDesc sphere_in_environment(Vec3 sigma_t, Vec3 albedo, float g,
                                       BoundaryType boundary, bool point_light = false) {
    SceneDesc d;
    d.source = "test-sphere";
    d.camera.origin = {0, 0, 3.5f};
    d.camera.target = {0, 0, 0};
    d.camera.fov = 40.f;
    d.camera.width = d.camera.height = 16;
    Shape s;
    s.name = "sphere";
    s.mesh = make_icosphere({0, 0, 0}, 1.f, 3);
    s.medium = {sigma_t, albedo, g};
    s.boundary.type = boundary;
    d.shapes.push_back(s);
    Light env;
    env.type = Light::Type::Environment;
    env.radiance = Vec3(1.f);
    d.lights.push_back(env);
    if (point_light) {
        Light p;
        p.type = Light::Type::Point;
        p.position = {2.f, 2.f, 2.f};
        p.intensity = Vec3(5.f);
        d.lights.push_back(p);
    }
    d.render.grid_resolution = 16;
    return d;
}

}  // namespace sss::test

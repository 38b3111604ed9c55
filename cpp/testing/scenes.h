// Small scenes built in code for the C++ tests of render/.
#pragma once

#include "geometry/mesh.h"
#include "render/scene.h"

namespace sss {

// The tests' shorthand for the two boundary types they use.
enum class BoundaryType { IndexMatched, Dielectric };

namespace test {

inline Boundary boundary(BoundaryType type) {
    return parse_boundary(type == BoundaryType::Dielectric
                              ? R"({"type": "dielectric"})"
                              : R"({"type": "index_matched"})");
}

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
    s.medium.sigma_t = sigma_t;
    s.medium.albedo = albedo;
    s.medium.phase.x = g;  // Henyey-Greenstein
    s.boundary = test::boundary(boundary);
    d.shapes.push_back(s);
    d.lights.push_back(parse_light(R"({"type": "environment", "radiance": 1})"));
    if (point_light)
        d.lights.push_back(parse_light(
            R"({"type": "point", "position": [2, 2, 2], "intensity": [5, 5, 5]})"));
    d.render.grid_resolution = 16;
    return d;
}

}  // namespace test
}  // namespace sss

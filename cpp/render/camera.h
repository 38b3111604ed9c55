// Pinhole camera with look-at and vertical field of view. Pixel (0, 0) is the top-left;
// (x + 0.5, y + 0.5) is a pixel's centre; image x grows to the right of the view.
#pragma once

#include <cmath>

#include "core/vec.h"
#include "render/scene.h"

namespace sss {

class PinholeCamera {
public:
    explicit PinholeCamera(const Camera& c)
        : origin_(c.origin), width_(c.width), height_(c.height) {
        // unit_normal: target and up may be long past float's squares (1.8e19)
        forward_ = unit_normal(c.target - c.origin);
        right_ = unit_normal(cross(forward_, c.up));
        up_ = cross(right_, forward_);
        tan_half_ = std::tan(0.5f * c.fov * 0.017453292519943295f);
        aspect_ = float(c.width) / float(c.height);
    }
    Vec3 origin() const { return origin_; }
    // Unit direction through film position (fx, fy) in pixels.
    Vec3 direction(float fx, float fy) const {
        float u = (2.f * fx / float(width_) - 1.f) * tan_half_ * aspect_;
        float v = (1.f - 2.f * fy / float(height_)) * tan_half_;
        return normalize(forward_ + right_ * u + up_ * v);
    }

private:
    Vec3 origin_, forward_, right_, up_;
    int width_, height_;
    float tan_half_, aspect_;
};

}  // namespace sss

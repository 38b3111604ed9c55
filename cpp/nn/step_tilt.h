// PathGen's forward-memory tilt (docs/sphere-tracing.md, "The forward-memory tilt";
// docs/model-format.md, "tilt.json"): per (sigma, g) the coefficients (a, b) with which a
// learned step is kept (shared/sphere_step.h, tilt_acceptance), tabulated at nodes of
// sigma and g and interpolated bilinearly in (ln sigma, g), clamped at the outer nodes.
#pragma once

#include <string>
#include <vector>

namespace sss {

constexpr const char* kTiltFormat = "sssphere-step-tilt";
constexpr int kTiltFormatVersion = 1;
// Each coefficient's size is bounded so that a step is kept with probability at least
// (1 - 0.9) / (1 + 0.9) = 0.05 per draw.
constexpr float kTiltMaxSum = 0.9f;

struct StepTilt {
    std::vector<float> log_sigma, g;  // the nodes (ln sigma), increasing
    std::vector<float> a, b;          // a[i_g * log_sigma.size() + i_sigma]
    std::string source;               // the file, for messages

    bool empty() const { return a.empty(); }
    // (a, b) at (sigma, g) (sigma > 0); (0, 0) when empty.
    void at(float sigma, float g, float* a_out, float* b_out) const;
};

// The tilt in file `path` (docs/model-format.md); throws sss::Error naming the file, the
// field and the value where it is not one.
StepTilt load_step_tilt(const std::string& path);
StepTilt parse_step_tilt(const std::string& text, const std::string& source);

}  // namespace sss

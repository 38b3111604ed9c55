// Measured media for the scene file's "preset" (docs/scene-format.md, "Ways to state a
// medium"): reduced scattering sigma_s' = sigma_s (1 - g) and absorption sigma_a, per RGB
// channel, in mm^-1, from two papers:
// - Jensen, Marschner, Levoy, Hanrahan, "A Practical Model for Subsurface Light
//   Transport", SIGGRAPH 2001 (materials, with their index of refraction);
// - Narasimhan, Gupta, Donner, Ramamoorthi, Nayar, Jensen, "Acquiring Scattering
//   Properties of Participating Media by Dilution", SIGGRAPH 2006 (liquids; no index).
// The numbers are the papers' as reproduced in pbrt-v4's media.cpp; see
// docs/scene-format.md for how they were checked.
#pragma once

#include <cmath>
#include <vector>

#include "core/vec.h"

namespace sss {

struct MediumPreset {
    const char* name;    // the scene file's "preset"
    Vec3 sigma_s_prime;  // reduced scattering, mm^-1
    Vec3 sigma_a;        // absorption, mm^-1
    float ior;           // index of refraction the source gives, 0: none
    const char* source;
};

inline const std::vector<MediumPreset>& medium_presets() {
    static const char* kJensen = "Jensen et al. 2001";
    static const char* kNarasimhan = "Narasimhan et al. 2006";
    // clang-format off
    static const std::vector<MediumPreset> presets = {
        {"apple", {2.29f, 2.39f, 1.97f}, {0.0030f, 0.0034f, 0.046f}, 1.3f, kJensen},
        {"chicken1", {0.15f, 0.21f, 0.38f}, {0.015f, 0.077f, 0.19f}, 1.3f, kJensen},
        {"chicken2", {0.19f, 0.25f, 0.32f}, {0.018f, 0.088f, 0.20f}, 1.3f, kJensen},
        {"cream", {7.38f, 5.47f, 3.15f}, {0.0002f, 0.0028f, 0.0163f}, 1.3f, kJensen},
        {"ketchup", {0.18f, 0.07f, 0.03f}, {0.061f, 0.97f, 1.45f}, 1.3f, kJensen},
        {"marble", {2.19f, 2.62f, 3.00f}, {0.0021f, 0.0041f, 0.0071f}, 1.5f, kJensen},
        {"potato", {0.68f, 0.70f, 0.55f}, {0.0024f, 0.0090f, 0.12f}, 1.3f, kJensen},
        {"skimmilk", {0.70f, 1.22f, 1.90f}, {0.0014f, 0.0025f, 0.0142f}, 1.3f, kJensen},
        {"skin1", {0.74f, 0.88f, 1.01f}, {0.032f, 0.17f, 0.48f}, 1.3f, kJensen},
        {"skin2", {1.09f, 1.59f, 1.79f}, {0.013f, 0.070f, 0.145f}, 1.3f, kJensen},
        {"spectralon", {11.6f, 20.4f, 14.9f}, {0.0f, 0.0f, 0.0f}, 1.3f, kJensen},
        {"wholemilk", {2.55f, 3.21f, 3.77f}, {0.0011f, 0.0024f, 0.014f}, 1.3f, kJensen},
        {"lowfat_milk", {0.89187f, 1.5136f, 2.532f}, {0.002875f, 0.00575f, 0.0115f}, 0.f, kNarasimhan},
        {"reduced_milk", {2.4858f, 3.1669f, 4.5214f}, {0.0025556f, 0.0051111f, 0.012778f}, 0.f, kNarasimhan},
        {"regular_milk", {4.5513f, 5.8294f, 7.136f}, {0.0015333f, 0.0046f, 0.019933f}, 0.f, kNarasimhan},
        {"espresso", {0.72378f, 0.84557f, 1.0247f}, {4.7984f, 6.5751f, 8.8493f}, 0.f, kNarasimhan},
        {"mint_mocha_coffee", {0.31602f, 0.38538f, 0.48131f}, {3.772f, 5.8228f, 7.82f}, 0.f, kNarasimhan},
        {"lowfat_soy_milk", {0.30576f, 0.34233f, 0.61664f}, {0.0014375f, 0.0071875f, 0.035937f}, 0.f, kNarasimhan},
        {"regular_soy_milk", {0.59223f, 0.73866f, 1.4693f}, {0.0019167f, 0.0095833f, 0.065167f}, 0.f, kNarasimhan},
        {"lowfat_chocolate_milk", {0.64925f, 0.83916f, 1.1057f}, {0.0115f, 0.0368f, 0.1564f}, 0.f, kNarasimhan},
        {"regular_chocolate_milk", {1.4585f, 2.1289f, 2.9527f}, {0.010063f, 0.043125f, 0.14375f}, 0.f, kNarasimhan},
        {"coke", {8.9053e-05f, 8.372e-05f, 0.f}, {0.10014f, 0.16503f, 0.2468f}, 0.f, kNarasimhan},
        {"pepsi", {6.1697e-05f, 4.2564e-05f, 0.f}, {0.091641f, 0.14158f, 0.20729f}, 0.f, kNarasimhan},
        {"sprite", {6.0306e-06f, 6.4139e-06f, 6.5504e-06f}, {0.001886f, 0.0018308f, 0.0020025f}, 0.f, kNarasimhan},
        {"gatorade", {0.0024574f, 0.003007f, 0.0037325f}, {0.024794f, 0.019289f, 0.008878f}, 0.f, kNarasimhan},
        {"chardonnay", {1.7982e-05f, 1.3758e-05f, 1.2023e-05f}, {0.010782f, 0.011855f, 0.023997f}, 0.f, kNarasimhan},
        {"white_zinfandel", {1.7501e-05f, 1.9069e-05f, 1.288e-05f}, {0.012072f, 0.016184f, 0.019843f}, 0.f, kNarasimhan},
        {"merlot", {2.1129e-05f, 0.f, 0.f}, {0.11632f, 0.25191f, 0.29434f}, 0.f, kNarasimhan},
        {"budweiser_beer", {2.4356e-05f, 2.4079e-05f, 1.0564e-05f}, {0.011492f, 0.024911f, 0.057786f}, 0.f, kNarasimhan},
        {"coors_light_beer", {5.0922e-05f, 4.301e-05f, 0.f}, {0.006164f, 0.013984f, 0.034983f}, 0.f, kNarasimhan},
        {"clorox", {0.0024035f, 0.0031373f, 0.003991f}, {0.0033542f, 0.014892f, 0.026297f}, 0.f, kNarasimhan},
        {"apple_juice", {0.00013612f, 0.00015836f, 0.000227f}, {0.012957f, 0.023741f, 0.052184f}, 0.f, kNarasimhan},
        {"cranberry_juice", {0.00010402f, 0.00011646f, 7.8139e-05f}, {0.039437f, 0.094223f, 0.12426f}, 0.f, kNarasimhan},
        {"grape_juice", {5.382e-05f, 0.f, 0.f}, {0.10404f, 0.23958f, 0.29325f}, 0.f, kNarasimhan},
        {"ruby_grapefruit_juice", {0.011002f, 0.010927f, 0.011036f}, {0.085867f, 0.18314f, 0.25262f}, 0.f, kNarasimhan},
        {"white_grapefruit_juice", {0.22826f, 0.23998f, 0.32748f}, {0.0138f, 0.018831f, 0.056781f}, 0.f, kNarasimhan},
        {"shampoo", {0.0007176f, 0.0008303f, 0.0009016f}, {0.014107f, 0.045693f, 0.061717f}, 0.f, kNarasimhan},
        {"strawberry_shampoo", {0.00015671f, 0.00015947f, 1.518e-05f}, {0.01449f, 0.05796f, 0.075823f}, 0.f, kNarasimhan},
        {"head_and_shoulders_shampoo", {0.023805f, 0.028804f, 0.034306f}, {0.084621f, 0.15688f, 0.20365f}, 0.f, kNarasimhan},
        {"lemon_tea_powder", {0.040224f, 0.045264f, 0.051081f}, {2.4288f, 4.5757f, 7.2127f}, 0.f, kNarasimhan},
        {"orange_powder", {0.00015617f, 0.00017482f, 0.0001762f}, {0.001449f, 0.003441f, 0.007863f}, 0.f, kNarasimhan},
        {"pink_lemonade_powder", {0.00012103f, 0.00013073f, 0.00012528f}, {0.001165f, 0.002366f, 0.003195f}, 0.f, kNarasimhan},
        {"cappuccino_powder", {1.8436f, 2.5851f, 2.1662f}, {35.844f, 49.547f, 61.084f}, 0.f, kNarasimhan},
        {"salt_powder", {0.027333f, 0.032451f, 0.031979f}, {0.28415f, 0.3257f, 0.34148f}, 0.f, kNarasimhan},
        {"sugar_powder", {0.00022272f, 0.00025513f, 0.000271f}, {0.012638f, 0.031051f, 0.050124f}, 0.f, kNarasimhan},
        {"suisse_mocha_powder", {2.7979f, 3.5452f, 4.3365f}, {17.502f, 27.004f, 35.433f}, 0.f, kNarasimhan},
        {"pacific_ocean_surface_water", {0.0001764f, 0.00032095f, 0.00019617f}, {0.031845f, 0.031324f, 0.030147f}, 0.f, kNarasimhan},
    };
    // clang-format on
    return presets;
}

// Reduced coefficients per scene unit (sigma_s' = sigma_s (1 - g)).
struct ReducedCoefficients {
    Vec3 sigma_s_prime, sigma_a;
};

// A medium as a user sees it: "color", the multiple-scattering albedo A (what a thick
// slab of it reflects), and "mean_free_path" d, per channel, inverted with the fit of
// Chiang, Kutz and Burley, "Practical and Controllable Subsurface Scattering for
// Production Path Tracing" (SIGGRAPH 2016 talk), made for isotropic scattering and
// applied here to the reduced coefficients (docs/scene-format.md):
//   alpha' = 1 - exp(-5.09406 A + 2.61188 A^2 - 4.31805 A^3),  s = 1.9 - A + 3.5 (A -
//   0.8)^2, sigma_t' = 1 / (d s),  sigma_s' = alpha' sigma_t',  sigma_a = sigma_t' -
//   sigma_s'.
inline ReducedCoefficients invert_multiple_scattering_albedo(Vec3 color,
                                                             Vec3 mean_free_path) {
    ReducedCoefficients r;
    for (int c = 0; c < 3; ++c) {
        const double a = color[c];
        const double alpha = 1.0 - std::exp(a * (-5.09406 + a * (2.61188 - a * 4.31805)));
        const double s = 1.9 - a + 3.5 * (a - 0.8) * (a - 0.8);
        const double sigma_t = 1.0 / (double(mean_free_path[c]) * s);
        r.sigma_s_prime[c] = float(alpha * sigma_t);
        r.sigma_a[c] = float((1.0 - alpha) * sigma_t);
    }
    return r;
}

// The forward direction of the same fit: the multiple-scattering albedo (the diffuse
// reflectance of a thick slab, `color`) of a medium whose reduced single-scattering
// albedo is alpha' = sigma_s' / (sigma_s' + sigma_a), found by bisection (alpha' grows
// with A); 1 where alpha' is beyond the fit's value at A = 1. The first-hit albedo AOV
// (render/aovs.h) reports a medium by it.
inline float multiple_scattering_albedo(float reduced_albedo) {
    auto fit = [](double a) {
        return 1.0 - std::exp(a * (-5.09406 + a * (2.61188 - a * 4.31805)));
    };
    if (!(reduced_albedo > 0.f)) return 0.f;
    if (reduced_albedo >= fit(1.0)) return 1.f;
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 40; ++i) {
        const double mid = 0.5 * (lo + hi);
        (fit(mid) < reduced_albedo ? lo : hi) = mid;
    }
    return float(0.5 * (lo + hi));
}

}  // namespace sss

#include "shared/fresnel.h"

#include <gtest/gtest.h>

using namespace sss;

TEST(Fresnel, NormalIncidence) {
    float ct;
    float eta = 1.5f;
    EXPECT_NEAR(fresnel_dielectric(1.f, eta, ct),
                (eta - 1) * (eta - 1) / ((eta + 1) * (eta + 1)), 1e-6f);
    EXPECT_NEAR(ct, 1.f, 1e-6f);
}

TEST(Fresnel, TotalInternalReflectionBeyondCriticalAngle) {
    float ct;
    float eta = 1.f / 1.5f;  // from glass to vacuum
    float cos_crit = std::sqrt(1.f - eta * eta);
    EXPECT_EQ(fresnel_dielectric(cos_crit - 1e-3f, eta, ct), 1.f);
    EXPECT_LT(fresnel_dielectric(cos_crit + 1e-2f, eta, ct), 1.f);
}

// Reflectance is the same seen from either side of the interface (Stokes relations).
TEST(Fresnel, Reciprocity) {
    for (float ci = 0.05f; ci <= 1.f; ci += 0.05f) {
        float ct, back;
        float r = fresnel_dielectric(ci, 1.5f, ct);
        float r2 = fresnel_dielectric(ct, 1.f / 1.5f, back);
        EXPECT_NEAR(r, r2, 1e-5f);
        EXPECT_NEAR(back, ci, 1e-5f);
    }
}

TEST(Fresnel, GrazingIncidenceReflectsEverything) {
    float ct;
    EXPECT_NEAR(fresnel_dielectric(1e-6f, 1.5f, ct), 1.f, 1e-4f);
}

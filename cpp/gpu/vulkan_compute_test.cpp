#include "gpu/vulkan_compute.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <memory>
#include <random>
#include <vector>

#include "testing/errors.h"

namespace sss {
namespace {

static const uint32_t kTestAxpy[] =
#include "shaders/test_axpy.spv.h"
    ;

using test::error_of;

// Each test runs twice: with the device's default memory path (host-visible device memory
// written in place on lavapipe and integrated GPUs) and through the staging buffer that
// discrete GPUs use.
class VulkanComputeTest : public ::testing::TestWithParam<bool> {
protected:
    void SetUp() override {
        try {
            VulkanCompute::Options options;
            options.force_staging = GetParam();
            vk = std::make_unique<VulkanCompute>(options);
        } catch (const GpuUnavailable& e) {
            GTEST_SKIP() << "no Vulkan device: " << e.what();
        }
    }
    std::unique_ptr<VulkanCompute> vk;
};

struct AxpyPush {
    float a;
    uint32_t n;
};

TEST_P(VulkanComputeTest, DescribesDevice) {
    EXPECT_FALSE(vk->device_name().empty());
    EXPECT_GE(vk->max_workgroup_invocations(), 128u);  // Vulkan's minimum
    EXPECT_GE(vk->max_workgroups_x(), 65535u);         // Vulkan's minimum
    EXPECT_GE(vk->max_storage_buffer_bytes(), size_t(1) << 27);
    RecordProperty("device", vk->device_name());
}

TEST_P(VulkanComputeTest, AxpyMatchesCpu) {
    const uint32_t n = 100003;  // not a multiple of the workgroup size 64
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> u(-10.0f, 10.0f);
    std::vector<float> x(n), y(n);
    for (uint32_t i = 0; i < n; ++i) x[i] = u(rng), y[i] = u(rng);
    const AxpyPush push{1.7f, n};

    const VulkanCompute::BufferId bx = vk->create_buffer(n * sizeof(float));
    const VulkanCompute::BufferId by = vk->create_buffer(n * sizeof(float));
    vk->upload(bx, x.data(), n * sizeof(float));
    vk->upload(by, y.data(), n * sizeof(float));
    const VulkanCompute::PipelineId axpy =
        vk->create_pipeline(kTestAxpy, std::size(kTestAxpy), 2, sizeof push);
    const double seconds = vk->run(axpy, {bx, by}, &push, sizeof push, (n + 63) / 64);
    EXPECT_GT(seconds, 0.0);
    EXPECT_TRUE(std::isfinite(seconds));

    // by now holds a x + y_before. The GPU may fuse the multiply-add: allow a rounding of
    // the terms' size.
    auto expect_axpy = [&](const std::vector<float>& y_before) {
        std::vector<float> out(n);
        vk->download(by, out.data(), n * sizeof(float));
        for (uint32_t i = 0; i < n; ++i) {
            const float expect = push.a * x[i] + y_before[i];
            const float scale = std::abs(push.a * x[i]) + std::abs(y_before[i]);
            EXPECT_NEAR(out[i], expect, 1e-6f * scale) << "i = " << i;
            if (::testing::Test::HasFailure()) break;
        }
        return out;
    };
    const std::vector<float> once = expect_axpy(y);
    // The same pipeline again, as a 2D dispatch of 2 x 782 groups of 64 (>= n lanes)
    vk->run(axpy, {bx, by}, &push, sizeof push, 2, 782);
    expect_axpy(once);
}

TEST_P(VulkanComputeTest, LargeBufferRoundTrips) {
    const size_t bytes = size_t(300) << 20;
    const VulkanCompute::BufferId b = vk->create_buffer(bytes);
    EXPECT_EQ(vk->buffer_size(b), bytes);
    std::vector<uint32_t> pattern(bytes / 4);
    for (size_t i = 0; i < pattern.size(); ++i) pattern[i] = uint32_t(i) * 2654435761u;
    vk->upload(b, pattern.data(), bytes);

    // A window at an odd offset, across the staging buffer's 64 MiB chunks
    const size_t offset = (size_t(130) << 20) - 13, len = (size_t(70) << 20) + 5;
    std::vector<char> window(len);
    vk->download(b, window.data(), len, offset);
    EXPECT_EQ(
        std::memcmp(window.data(), reinterpret_cast<char*>(pattern.data()) + offset, len),
        0);

    // Overwrite a piece at another odd offset, read the whole buffer back
    std::vector<char> piece(1000003);
    for (size_t i = 0; i < piece.size(); ++i) piece[i] = char(i * 7 + 1);
    const size_t at = bytes - piece.size() - 3;
    vk->upload(b, piece.data(), piece.size(), at);
    std::memcpy(reinterpret_cast<char*>(pattern.data()) + at, piece.data(), piece.size());
    std::vector<uint32_t> back(bytes / 4);
    vk->download(b, back.data(), bytes);
    EXPECT_TRUE(back == pattern);

    vk->fill_zero(b);
    vk->download(b, back.data(), bytes);
    EXPECT_TRUE(std::all_of(back.begin(), back.end(), [](uint32_t v) { return v == 0; }));

    // Larger than a storage buffer may be bound (lavapipe: 128 MiB): run() says so
    if (bytes > vk->max_storage_buffer_bytes()) {
        const VulkanCompute::PipelineId p =
            vk->create_pipeline(kTestAxpy, std::size(kTestAxpy), 2, sizeof(AxpyPush));
        const AxpyPush push{1.0f, 4};
        EXPECT_HAS(error_of([&] {
                       vk->run(p, {b, b}, &push, sizeof push, 1);
                   }),
                   "maxStorageBufferRange");
    }
}

TEST_P(VulkanComputeTest, RoundsSizesUp) {
    const VulkanCompute::BufferId b = vk->create_buffer(5);
    EXPECT_EQ(vk->buffer_size(b), 8u);
    const char in[5] = {1, 2, 3, 4, 5};
    char out[3] = {};
    vk->upload(b, in, 5);
    vk->download(b, out, 3, 2);
    EXPECT_EQ(out[0], 3);
    EXPECT_EQ(out[2], 5);
}

TEST_P(VulkanComputeTest, RejectsMisuse) {
    const VulkanCompute::BufferId b = vk->create_buffer(16);
    char data[16] = {};
    EXPECT_HAS(error_of([&] { vk->create_buffer(2); }), "at least 4");
    EXPECT_HAS(error_of([&] { vk->upload(b, data, 16, 4); }),
               "outside a buffer of 16 bytes");
    EXPECT_HAS(error_of([&] { vk->download(7, data, 4); }), "no buffer 7");
    EXPECT_HAS(error_of([&] { vk->create_pipeline(kTestAxpy, 3, 2, 8); }), "not SPIR-V");
    EXPECT_HAS(
        error_of([&] { vk->create_pipeline(kTestAxpy, std::size(kTestAxpy), 2, 6); }),
        "multiple of 4");
    const VulkanCompute::PipelineId p =
        vk->create_pipeline(kTestAxpy, std::size(kTestAxpy), 2, sizeof(AxpyPush));
    const AxpyPush push{1.0f, 4};
    EXPECT_HAS(error_of([&] { vk->run(p, {b}, &push, sizeof push, 1); }),
               "1 buffers for a pipeline of 2");
    EXPECT_HAS(error_of([&] {
                   vk->run(p, {b, b}, &push, 4, 1);
               }),
               "4 bytes of push constants for a pipeline of 8");
    EXPECT_HAS(error_of([&] {
                   vk->run(p + 1, {b, b}, &push, sizeof push, 1);
               }),
               "no pipeline");
    // Still usable after the errors
    EXPECT_GT(vk->run(p, {b, b}, &push, sizeof push, 1), 0.0);
}

INSTANTIATE_TEST_SUITE_P(Memory, VulkanComputeTest, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& info) {
                             return info.param ? "Staging" : "Default";
                         });

}  // namespace
}  // namespace sss

// The lowest GPU layer: one Vulkan device, storage buffers and compute pipelines, and a
// synchronous run() that dispatches one pipeline and returns its GPU time. Everything the
// renderer's shaders need and nothing else (no graphics, no swapchain, no validation
// layers). Vulkan's own headers stay in vulkan_compute.cpp.
//
// All calls are synchronous and the class is not thread-safe: each call records one
// command buffer, submits it and waits on a fence before it returns, so a buffer may be
// read or written by the host as soon as the call that used it has returned. Buffers and
// pipelines live as long as the VulkanCompute that made them.
//
// Without a GPU, Mesa's lavapipe (mesa-vulkan-drivers) runs the shaders on the CPU; force
// it with VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json. Its limits are
// small: a storage buffer binds at most 128 MiB (max_storage_buffer_bytes()).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/check.h"

namespace sss {

// Thrown when there is no usable Vulkan loader or device (tests skip on it, users get the
// message).
struct GpuUnavailable : Error {
    using Error::Error;
};

class VulkanCompute {
public:
    struct Options {
        // Move data through a host-visible staging buffer even where device memory is
        // host-visible (lavapipe, integrated GPUs): the path discrete GPUs take, for
        // tests.
        bool force_staging = false;
    };

    // Loads Vulkan (instance API 1.1+; validation layers off) and picks a physical device
    // with a compute queue and shaderInt64, preferring discrete GPU > integrated >
    // virtual > CPU (lavapipe). Throws GpuUnavailable if the loader finds no driver or no
    // such device (naming the devices without shaderInt64), Error for other Vulkan
    // failures.
    VulkanCompute();
    explicit VulkanCompute(const Options& options);
    ~VulkanCompute();  // waits for the device, frees everything
    VulkanCompute(const VulkanCompute&) = delete;
    VulkanCompute& operator=(const VulkanCompute&) = delete;

    const std::string& device_name() const;
    bool is_software() const;                    // VK_PHYSICAL_DEVICE_TYPE_CPU (lavapipe)
    uint32_t max_workgroup_invocations() const;  // maxComputeWorkGroupInvocations
    uint32_t max_workgroups_x() const;           // maxComputeWorkGroupCount[0]
    // The largest buffer run() can bind (maxStorageBufferRange; 128 MiB on lavapipe).
    size_t max_storage_buffer_bytes() const;

    using BufferId = int;
    // A storage buffer of `bytes` (>= 4), rounded up to a multiple of 4; its contents are
    // undefined until written. Device-local memory with a staging copy, or host-visible
    // device memory written directly where the device has it and is not discrete.
    BufferId create_buffer(size_t bytes);
    // Copy `bytes` between host memory and bytes [offset, offset + bytes) of buffer b;
    // any size and offset within the buffer (no alignment needed).
    void upload(BufferId b, const void* data, size_t bytes, size_t offset = 0);
    void download(BufferId b, void* data, size_t bytes, size_t offset = 0);
    void fill_zero(BufferId b);
    size_t buffer_size(BufferId b) const;  // as rounded up by create_buffer

    using PipelineId = int;
    // A compute pipeline from SPIR-V words (entry point "main"): descriptor set 0 has
    // `num_buffers` storage buffers at bindings 0 .. num_buffers-1, plus `push_bytes`
    // (<= 128, a multiple of 4) of push constants at offset 0. The words are copied.
    // `constants` are the shader's specialization constants, constant_id i = constants[i]
    // (32-bit ints); the driver compiles the pipeline with their values. Bit i of
    // `uniform_bindings` makes binding i a uniform buffer instead (at most 4; for small
    // read-only data that every invocation reads alike, such as network weights).
    PipelineId create_pipeline(const uint32_t* spirv, size_t words, int num_buffers,
                               uint32_t push_bytes,
                               const std::vector<int32_t>& constants = {},
                               uint32_t uniform_bindings = 0);
    // Dispatches groups_x * groups_y * groups_z workgroups of `pipeline` with buffers[i]
    // (whole) at binding i and `push_bytes` of push constants (exactly the pipeline's),
    // waits for completion and returns the GPU time of the dispatch in seconds from
    // timestamp queries, or the host's wall time around submit and wait where the queue
    // has no timestamps. Writes of earlier calls are visible to the dispatch, its writes
    // to later calls.
    double run(PipelineId pipeline, const std::vector<BufferId>& buffers,
               const void* push, uint32_t push_bytes, uint32_t groups_x,
               uint32_t groups_y = 1, uint32_t groups_z = 1);

private:
    struct Impl;
    std::unique_ptr<Impl> m_;
};

}  // namespace sss

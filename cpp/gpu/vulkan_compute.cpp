#include "gpu/vulkan_compute.h"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <vector>

namespace sss {
namespace {

// Staging buffer size: uploads and downloads through it go in chunks of this many bytes.
constexpr VkDeviceSize kStagingBytes = VkDeviceSize(64) << 20;
// Most storage buffers one pipeline may bind (also capped by the device's limits).
constexpr uint32_t kMaxBindings = 32;
constexpr uint32_t kMaxPushBytes = 128;
constexpr uint32_t kMaxUniformBindings = 4;
constexpr uint32_t kSpirvMagic = 0x07230203;
// The only stages that touch buffers here: copies and fills, and compute shaders
constexpr VkPipelineStageFlags kStages =
    VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
constexpr VkAccessFlags kWrites =
    VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT;

std::string result_name(VkResult r) {
    switch (r) {
#define SSS_VK_CASE(x) \
    case x:            \
        return #x;
        SSS_VK_CASE(VK_SUCCESS)
        SSS_VK_CASE(VK_NOT_READY)
        SSS_VK_CASE(VK_TIMEOUT)
        SSS_VK_CASE(VK_INCOMPLETE)
        SSS_VK_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
        SSS_VK_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        SSS_VK_CASE(VK_ERROR_INITIALIZATION_FAILED)
        SSS_VK_CASE(VK_ERROR_DEVICE_LOST)
        SSS_VK_CASE(VK_ERROR_MEMORY_MAP_FAILED)
        SSS_VK_CASE(VK_ERROR_LAYER_NOT_PRESENT)
        SSS_VK_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
        SSS_VK_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
        SSS_VK_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
        SSS_VK_CASE(VK_ERROR_TOO_MANY_OBJECTS)
        SSS_VK_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
        SSS_VK_CASE(VK_ERROR_FRAGMENTED_POOL)
        SSS_VK_CASE(VK_ERROR_UNKNOWN)
        SSS_VK_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
        SSS_VK_CASE(VK_ERROR_INVALID_EXTERNAL_HANDLE)
        SSS_VK_CASE(VK_ERROR_FRAGMENTATION)
        SSS_VK_CASE(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
        SSS_VK_CASE(VK_PIPELINE_COMPILE_REQUIRED)
        SSS_VK_CASE(VK_ERROR_INVALID_SHADER_NV)
#undef SSS_VK_CASE
        default:
            return "VkResult " + std::to_string(int(r));
    }
}

// Every Vulkan call that returns a VkResult goes through check().
void check(VkResult r, const char* call) {
    if (r != VK_SUCCESS) fail("Vulkan: ", call, " failed: ", result_name(r));
}

const char* type_name(VkPhysicalDeviceType t) {
    switch (t) {
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
            return "discrete GPU";
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
            return "integrated GPU";
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
            return "virtual GPU";
        case VK_PHYSICAL_DEVICE_TYPE_CPU:
            return "CPU";
        default:
            return "other";
    }
}

// Higher is preferred: discrete > integrated > virtual > CPU > other.
int type_rank(VkPhysicalDeviceType t) {
    switch (t) {
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
            return 4;
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
            return 3;
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
            return 2;
        case VK_PHYSICAL_DEVICE_TYPE_CPU:
            return 1;
        default:
            return 0;
    }
}

// The first memory type in `type_bits` with all of `required`, preferring one that also
// has all of `preferred`; -1 if there is none.
int find_memory_type(const VkPhysicalDeviceMemoryProperties& mp, uint32_t type_bits,
                     VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred) {
    int found = -1;
    for (uint32_t i = 0; i < mp.memoryTypeCount; ++i) {
        VkMemoryPropertyFlags f = mp.memoryTypes[i].propertyFlags;
        if (!(type_bits & (1u << i)) || (f & required) != required) continue;
        if ((f & preferred) == preferred) return int(i);
        if (found < 0) found = int(i);
    }
    return found;
}

}  // namespace

struct VulkanCompute::Impl {
    struct Buffer {
        VkBuffer buffer = VK_NULL_HANDLE;
        VkDeviceMemory memory = VK_NULL_HANDLE;
        size_t size = 0;
        // Set where the host reads and writes the memory in place (persistently mapped)
        char* mapped = nullptr;
    };
    struct Pipeline {
        VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
        VkPipelineLayout layout = VK_NULL_HANDLE;
        VkPipeline pipeline = VK_NULL_HANDLE;
        int num_buffers = 0;
        uint32_t push_bytes = 0;
        uint32_t uniform_mask = 0;  // bit i: binding i is a uniform buffer
    };

    Options options;
    VkInstance instance = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties props{};
    VkPhysicalDeviceMemoryProperties memory_props{};
    VkDeviceSize max_allocation = 0;  // maxMemoryAllocationSize
    std::string name;
    uint32_t queue_family = 0;
    uint32_t timestamp_bits = 0;  // of the queue family; 0: no timestamps
    uint32_t max_bindings = 0;
    bool direct = false;  // host-visible device memory, read and written in place

    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    VkCommandPool command_pool = VK_NULL_HANDLE;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkQueryPool query_pool = VK_NULL_HANDLE;
    VkDescriptorPool descriptor_pool = VK_NULL_HANDLE;  // one set, reset by every run()

    Buffer staging;  // host-visible, made on first need (never where `direct`)
    std::vector<Buffer> buffers;
    std::vector<Pipeline> pipelines;

    explicit Impl(const Options& o);
    ~Impl();
    void create_instance();
    void pick_physical_device();
    void create_device();

    Buffer make_buffer(VkDeviceSize bytes, VkBufferUsageFlags usage, bool host_access);
    void destroy(Buffer& b);
    void destroy(Pipeline& p);
    Buffer& buffer(BufferId id, const char* call);
    void check_range(const Buffer& b, size_t bytes, size_t offset,
                     const char* call) const;
    Buffer& staging_buffer();

    // Each command: begin() (which orders it after every earlier command), record,
    // submit_and_wait() (which makes its writes visible to the host and later commands).
    void begin();
    void submit_and_wait();
};

VulkanCompute::Impl::Impl(const Options& o) : options(o) {
    create_instance();
    pick_physical_device();
    create_device();
}

void VulkanCompute::Impl::create_instance() {
    uint32_t version = 0;
    VkResult r = vkEnumerateInstanceVersion(&version);
    if (r != VK_SUCCESS || version < VK_API_VERSION_1_1)
        throw GpuUnavailable("Vulkan: the loader supports only Vulkan 1.0 (1.1 needed)");

    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "sssphere";
    app.pEngineName = "sssphere";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    info.pApplicationInfo = &app;
    r = vkCreateInstance(&info, nullptr, &instance);
    if (r == VK_ERROR_OUT_OF_HOST_MEMORY) check(r, "vkCreateInstance");
    if (r != VK_SUCCESS) {
        instance = VK_NULL_HANDLE;
        throw GpuUnavailable(
            "Vulkan: vkCreateInstance failed: " + result_name(r) +
            " (no usable Vulkan driver; VK_LOADER_DEBUG=driver says why; without a "
            "GPU, mesa-vulkan-drivers provides lavapipe)");
    }
}

void VulkanCompute::Impl::pick_physical_device() {
    uint32_t count = 0;
    VkResult r = vkEnumeratePhysicalDevices(instance, &count, nullptr);
    if (r != VK_SUCCESS && r != VK_INCOMPLETE)
        throw GpuUnavailable("Vulkan: vkEnumeratePhysicalDevices failed: " +
                             result_name(r));
    std::vector<VkPhysicalDevice> devices(count);
    if (count > 0) {
        r = vkEnumeratePhysicalDevices(instance, &count, devices.data());
        if (r != VK_SUCCESS && r != VK_INCOMPLETE)
            throw GpuUnavailable("Vulkan: vkEnumeratePhysicalDevices failed: " +
                                 result_name(r));
        devices.resize(count);
    }
    if (devices.empty()) throw GpuUnavailable("Vulkan: no physical device");

    // The best-ranked usable device (the first of equal rank); why others are not usable
    std::string rejected;
    int best_rank = -1;
    for (VkPhysicalDevice d : devices) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(d, &p);
        VkPhysicalDeviceFeatures features;
        vkGetPhysicalDeviceFeatures(d, &features);
        uint32_t nq = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(d, &nq, nullptr);
        std::vector<VkQueueFamilyProperties> families(nq);
        vkGetPhysicalDeviceQueueFamilyProperties(d, &nq, families.data());
        // A compute queue family, preferably one with timestamps
        int family = -1;
        for (uint32_t i = 0; i < nq; ++i) {
            if (!(families[i].queueFlags & VK_QUEUE_COMPUTE_BIT)) continue;
            if (family < 0 || (families[family].timestampValidBits == 0 &&
                               families[i].timestampValidBits > 0))
                family = int(i);
        }
        const char* reason = nullptr;
        if (p.apiVersion < VK_API_VERSION_1_1)
            reason = "Vulkan 1.0 only";
        else if (family < 0)
            reason = "no compute queue";
        else if (!features.shaderInt64)
            reason = "no shaderInt64";
        if (reason) {
            rejected += std::string(rejected.empty() ? "" : ", ") + "'" + p.deviceName +
                        "' (" + type_name(p.deviceType) + "): " + reason;
            continue;
        }
        if (type_rank(p.deviceType) > best_rank) {
            best_rank = type_rank(p.deviceType);
            physical = d;
            props = p;
            queue_family = uint32_t(family);
            timestamp_bits = families[family].timestampValidBits;
        }
    }
    if (physical == VK_NULL_HANDLE)
        throw GpuUnavailable("Vulkan: no usable device: " + rejected);

    name = props.deviceName;
    vkGetPhysicalDeviceMemoryProperties(physical, &memory_props);
    VkPhysicalDeviceMaintenance3Properties m3{};
    m3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
    VkPhysicalDeviceProperties2 p2{};
    p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    p2.pNext = &m3;
    vkGetPhysicalDeviceProperties2(physical, &p2);
    max_allocation = m3.maxMemoryAllocationSize;
    const VkPhysicalDeviceLimits& lim = props.limits;
    max_bindings = std::min({kMaxBindings, lim.maxPerStageDescriptorStorageBuffers,
                             lim.maxDescriptorSetStorageBuffers});
    // Unified memory (lavapipe, integrated GPUs): read and write device memory in place
    // where a type is device-local, host-visible and coherent. Discrete GPUs'
    // host-visible device memory (BAR) is small or slow to read, so they take the staging
    // path.
    direct = !options.force_staging &&
             (props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ||
              props.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU) &&
             find_memory_type(memory_props, ~0u,
                              VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT |
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                  VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                              0) >= 0;
}

void VulkanCompute::Impl::create_device() {
    float priority = 1.0f;
    VkDeviceQueueCreateInfo qinfo{};
    qinfo.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qinfo.queueFamilyIndex = queue_family;
    qinfo.queueCount = 1;
    qinfo.pQueuePriorities = &priority;
    VkPhysicalDeviceFeatures features{};
    features.shaderInt64 = VK_TRUE;
    VkDeviceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &qinfo;
    info.pEnabledFeatures = &features;
    VkResult r = vkCreateDevice(physical, &info, nullptr, &device);
    if (r != VK_SUCCESS) {
        device = VK_NULL_HANDLE;
        throw GpuUnavailable("Vulkan: vkCreateDevice failed for '" + name +
                             "': " + result_name(r));
    }
    vkGetDeviceQueue(device, queue_family, 0, &queue);

    VkCommandPoolCreateInfo pinfo{};
    pinfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pinfo.queueFamilyIndex = queue_family;
    check(vkCreateCommandPool(device, &pinfo, nullptr, &command_pool),
          "vkCreateCommandPool");
    VkCommandBufferAllocateInfo ainfo{};
    ainfo.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    ainfo.commandPool = command_pool;
    ainfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ainfo.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(device, &ainfo, &cmd), "vkAllocateCommandBuffers");
    VkFenceCreateInfo finfo{};
    finfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    check(vkCreateFence(device, &finfo, nullptr, &fence), "vkCreateFence");
    if (timestamp_bits > 0) {
        VkQueryPoolCreateInfo qpinfo{};
        qpinfo.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
        qpinfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
        qpinfo.queryCount = 2;
        check(vkCreateQueryPool(device, &qpinfo, nullptr, &query_pool),
              "vkCreateQueryPool");
    }
    const VkDescriptorPoolSize sizes[2] = {
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, max_bindings},
        {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, kMaxUniformBindings}};
    VkDescriptorPoolCreateInfo dinfo{};
    dinfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    dinfo.maxSets = 1;
    dinfo.poolSizeCount = 2;
    dinfo.pPoolSizes = sizes;
    check(vkCreateDescriptorPool(device, &dinfo, nullptr, &descriptor_pool),
          "vkCreateDescriptorPool");
}

VulkanCompute::Impl::~Impl() {
    if (device != VK_NULL_HANDLE) {
        vkDeviceWaitIdle(device);  // nothing to do on failure: everything goes anyway
        for (Pipeline& p : pipelines) destroy(p);
        for (Buffer& b : buffers) destroy(b);
        destroy(staging);
        vkDestroyDescriptorPool(device, descriptor_pool, nullptr);
        vkDestroyQueryPool(device, query_pool, nullptr);
        vkDestroyFence(device, fence, nullptr);
        vkDestroyCommandPool(device, command_pool, nullptr);  // frees cmd
        vkDestroyDevice(device, nullptr);
    }
    if (instance != VK_NULL_HANDLE) vkDestroyInstance(instance, nullptr);
}

VulkanCompute::Impl::Buffer VulkanCompute::Impl::make_buffer(VkDeviceSize bytes,
                                                             VkBufferUsageFlags usage,
                                                             bool host_access) {
    if (bytes > max_allocation)
        fail("VulkanCompute: a buffer of ", bytes, " bytes exceeds the device's ",
             "maxMemoryAllocationSize of ", max_allocation, " bytes ('", name, "')");
    Buffer b;
    b.size = size_t(bytes);
    try {
        VkBufferCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        info.size = bytes;
        info.usage = usage;
        info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
        check(vkCreateBuffer(device, &info, nullptr, &b.buffer), "vkCreateBuffer");
        VkMemoryRequirements req;
        vkGetBufferMemoryRequirements(device, b.buffer, &req);
        const VkMemoryPropertyFlags host =
            VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        // Host-visible memory preferably cached (fast reads by the host), device-local
        // too where the device reads it in place (`direct`; staging is then never made)
        int type = -1;
        if (host_access && direct)
            type = find_memory_type(memory_props, req.memoryTypeBits,
                                    host | VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT,
                                    VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        if (host_access && type < 0)
            type = find_memory_type(memory_props, req.memoryTypeBits, host,
                                    VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        if (!host_access)
            type = find_memory_type(memory_props, req.memoryTypeBits,
                                    VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0);
        if (!host_access && type < 0)
            type = find_memory_type(memory_props, req.memoryTypeBits, 0, 0);
        if (type < 0)
            fail("VulkanCompute: no ", host_access ? "host-visible coherent " : "",
                 "memory type for a buffer on '", name, "'");
        VkMemoryAllocateInfo ainfo{};
        ainfo.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        ainfo.allocationSize = req.size;
        ainfo.memoryTypeIndex = uint32_t(type);
        VkResult r = vkAllocateMemory(device, &ainfo, nullptr, &b.memory);
        if (r != VK_SUCCESS)
            fail("Vulkan: vkAllocateMemory of ", req.size,
                 " bytes failed: ", result_name(r));
        check(vkBindBufferMemory(device, b.buffer, b.memory, 0), "vkBindBufferMemory");
        if (host_access) {
            void* p = nullptr;
            check(vkMapMemory(device, b.memory, 0, VK_WHOLE_SIZE, 0, &p), "vkMapMemory");
            b.mapped = static_cast<char*>(p);
        }
    } catch (...) {
        destroy(b);
        throw;
    }
    return b;
}

void VulkanCompute::Impl::destroy(Buffer& b) {
    // Freeing the memory unmaps it
    if (b.buffer != VK_NULL_HANDLE) vkDestroyBuffer(device, b.buffer, nullptr);
    if (b.memory != VK_NULL_HANDLE) vkFreeMemory(device, b.memory, nullptr);
    b = Buffer{};
}

void VulkanCompute::Impl::destroy(Pipeline& p) {
    vkDestroyPipeline(device, p.pipeline, nullptr);
    vkDestroyPipelineLayout(device, p.layout, nullptr);
    vkDestroyDescriptorSetLayout(device, p.set_layout, nullptr);
    p = Pipeline{};
}

VulkanCompute::Impl::Buffer& VulkanCompute::Impl::buffer(BufferId id, const char* call) {
    if (id < 0 || size_t(id) >= buffers.size())
        fail("VulkanCompute::", call, ": no buffer ", id, " (", buffers.size(),
             " buffers made)");
    return buffers[size_t(id)];
}

void VulkanCompute::Impl::check_range(const Buffer& b, size_t bytes, size_t offset,
                                      const char* call) const {
    if (offset > b.size || bytes > b.size - offset)
        fail("VulkanCompute::", call, ": bytes [", offset, ", ", offset, " + ", bytes,
             ") outside a buffer of ", b.size, " bytes");
}

VulkanCompute::Impl::Buffer& VulkanCompute::Impl::staging_buffer() {
    if (staging.buffer == VK_NULL_HANDLE)
        staging = make_buffer(
            std::min(kStagingBytes, max_allocation),
            VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
    return staging;
}

void VulkanCompute::Impl::begin() {
    // The pool's only command buffer, free again since the last command waited
    check(vkResetCommandPool(device, command_pool, 0), "vkResetCommandPool");
    VkCommandBufferBeginInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    info.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(cmd, &info), "vkBeginCommandBuffer");
    // After every earlier command's writes (one queue: submission order); the host's
    // writes before vkQueueSubmit are visible by the submission itself.
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = kWrites;
    barrier.dstAccessMask =
        kWrites | VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_SHADER_READ_BIT;
    vkCmdPipelineBarrier(cmd, kStages, kStages, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

void VulkanCompute::Impl::submit_and_wait() {
    // The commands' writes made visible to the host (then the fence wait)
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = kWrites;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, kStages, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier, 0,
                         nullptr, 0, nullptr);
    check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    check(vkQueueSubmit(queue, 1, &submit, fence), "vkQueueSubmit");
    check(vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    check(vkResetFences(device, 1, &fence), "vkResetFences");
}

VulkanCompute::VulkanCompute() : VulkanCompute(Options{}) {}
VulkanCompute::VulkanCompute(const Options& options)
    : m_(std::make_unique<Impl>(options)) {}
VulkanCompute::~VulkanCompute() = default;

const std::string& VulkanCompute::device_name() const { return m_->name; }
bool VulkanCompute::is_software() const {
    return m_->props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
}
uint32_t VulkanCompute::max_workgroup_invocations() const {
    return m_->props.limits.maxComputeWorkGroupInvocations;
}
uint32_t VulkanCompute::max_workgroups_x() const {
    return m_->props.limits.maxComputeWorkGroupCount[0];
}
size_t VulkanCompute::max_storage_buffer_bytes() const {
    return m_->props.limits.maxStorageBufferRange;
}

VulkanCompute::BufferId VulkanCompute::create_buffer(size_t bytes) {
    if (bytes < 4) fail("VulkanCompute::create_buffer: ", bytes, " bytes (at least 4)");
    if (bytes > SIZE_MAX - 3) fail("VulkanCompute::create_buffer: ", bytes, " bytes");
    const VkBufferUsageFlags usage =
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT |
        VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    m_->buffers.push_back(m_->make_buffer((bytes + 3) / 4 * 4, usage, m_->direct));
    return BufferId(m_->buffers.size() - 1);
}

size_t VulkanCompute::buffer_size(BufferId b) const {
    return m_->buffer(b, "buffer_size").size;
}

void VulkanCompute::upload(BufferId b, const void* data, size_t bytes, size_t offset) {
    Impl::Buffer& buf = m_->buffer(b, "upload");
    m_->check_range(buf, bytes, offset, "upload");
    if (bytes == 0) return;
    if (!data) fail("VulkanCompute::upload: no data");
    const char* src = static_cast<const char*>(data);
    if (buf.mapped) {
        std::memcpy(buf.mapped + offset, src, bytes);
        return;
    }
    Impl::Buffer& staging = m_->staging_buffer();
    for (size_t done = 0; done < bytes;) {
        const size_t n = std::min(bytes - done, staging.size);
        std::memcpy(staging.mapped, src + done, n);
        m_->begin();
        VkBufferCopy region{0, VkDeviceSize(offset + done), VkDeviceSize(n)};
        vkCmdCopyBuffer(m_->cmd, staging.buffer, buf.buffer, 1, &region);
        m_->submit_and_wait();
        done += n;
    }
}

void VulkanCompute::download(BufferId b, void* data, size_t bytes, size_t offset) {
    Impl::Buffer& buf = m_->buffer(b, "download");
    m_->check_range(buf, bytes, offset, "download");
    if (bytes == 0) return;
    if (!data) fail("VulkanCompute::download: no data");
    char* dst = static_cast<char*>(data);
    if (buf.mapped) {
        std::memcpy(dst, buf.mapped + offset, bytes);
        return;
    }
    Impl::Buffer& staging = m_->staging_buffer();
    for (size_t done = 0; done < bytes;) {
        const size_t n = std::min(bytes - done, staging.size);
        m_->begin();
        VkBufferCopy region{VkDeviceSize(offset + done), 0, VkDeviceSize(n)};
        vkCmdCopyBuffer(m_->cmd, buf.buffer, staging.buffer, 1, &region);
        m_->submit_and_wait();
        std::memcpy(dst + done, staging.mapped, n);
        done += n;
    }
}

void VulkanCompute::fill_zero(BufferId b) {
    Impl::Buffer& buf = m_->buffer(b, "fill_zero");
    if (buf.mapped) {
        std::memset(buf.mapped, 0, buf.size);
        return;
    }
    m_->begin();
    vkCmdFillBuffer(m_->cmd, buf.buffer, 0, VK_WHOLE_SIZE, 0);
    m_->submit_and_wait();
}

VulkanCompute::PipelineId VulkanCompute::create_pipeline(
    const uint32_t* spirv, size_t words, int num_buffers, uint32_t push_bytes,
    const std::vector<int32_t>& constants, uint32_t uniform_bindings) {
    if (!spirv || words < 5 || spirv[0] != kSpirvMagic)
        fail("VulkanCompute::create_pipeline: not SPIR-V (", words,
             " words; the first must be 0x07230203)");
    if (num_buffers < 0 || uint32_t(num_buffers) > m_->max_bindings)
        fail("VulkanCompute::create_pipeline: ", num_buffers, " buffers (0 to ",
             m_->max_bindings, " on '", m_->name, "')");
    const uint32_t max_push =
        std::min(kMaxPushBytes, m_->props.limits.maxPushConstantsSize);
    if (push_bytes > max_push || push_bytes % 4 != 0)
        fail("VulkanCompute::create_pipeline: ", push_bytes,
             " bytes of push constants (a multiple of 4, at most ", max_push, ")");

    if ((num_buffers < 32 && (uniform_bindings >> num_buffers) != 0) ||
        uint32_t(__builtin_popcount(uniform_bindings)) > kMaxUniformBindings)
        fail("VulkanCompute::create_pipeline: uniform bindings mask ", uniform_bindings,
             " (at most ", kMaxUniformBindings, " of the ", num_buffers, " bindings)");
    VkDevice device = m_->device;
    Impl::Pipeline p;
    p.num_buffers = num_buffers;
    p.uniform_mask = uniform_bindings;
    p.push_bytes = push_bytes;
    VkShaderModule module = VK_NULL_HANDLE;
    try {
        std::vector<VkDescriptorSetLayoutBinding> bindings(
            static_cast<size_t>(num_buffers));
        for (int i = 0; i < num_buffers; ++i) {
            bindings[size_t(i)].binding = uint32_t(i);
            bindings[size_t(i)].descriptorType = (uniform_bindings >> i) & 1u
                                                     ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER
                                                     : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
            bindings[size_t(i)].descriptorCount = 1;
            bindings[size_t(i)].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
        }
        VkDescriptorSetLayoutCreateInfo sinfo{};
        sinfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
        sinfo.bindingCount = uint32_t(num_buffers);
        sinfo.pBindings = bindings.data();
        check(vkCreateDescriptorSetLayout(device, &sinfo, nullptr, &p.set_layout),
              "vkCreateDescriptorSetLayout");

        VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
        VkPipelineLayoutCreateInfo linfo{};
        linfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
        linfo.setLayoutCount = 1;
        linfo.pSetLayouts = &p.set_layout;
        linfo.pushConstantRangeCount = push_bytes > 0 ? 1 : 0;
        linfo.pPushConstantRanges = &range;
        check(vkCreatePipelineLayout(device, &linfo, nullptr, &p.layout),
              "vkCreatePipelineLayout");

        VkShaderModuleCreateInfo minfo{};
        minfo.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
        minfo.codeSize = words * sizeof(uint32_t);
        minfo.pCode = spirv;
        check(vkCreateShaderModule(device, &minfo, nullptr, &module),
              "vkCreateShaderModule");

        VkComputePipelineCreateInfo cinfo{};
        cinfo.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
        cinfo.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
        cinfo.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
        cinfo.stage.module = module;
        cinfo.stage.pName = "main";
        std::vector<VkSpecializationMapEntry> entries(constants.size());
        for (size_t i = 0; i < constants.size(); ++i)
            entries[i] = {uint32_t(i), uint32_t(i * sizeof(int32_t)), sizeof(int32_t)};
        VkSpecializationInfo spec{uint32_t(entries.size()), entries.data(),
                                  constants.size() * sizeof(int32_t), constants.data()};
        if (!constants.empty()) cinfo.stage.pSpecializationInfo = &spec;
        cinfo.layout = p.layout;
        check(vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &cinfo, nullptr,
                                       &p.pipeline),
              "vkCreateComputePipelines");
    } catch (...) {
        vkDestroyShaderModule(device, module, nullptr);
        m_->destroy(p);
        throw;
    }
    vkDestroyShaderModule(device, module, nullptr);
    m_->pipelines.push_back(p);
    return PipelineId(m_->pipelines.size() - 1);
}

double VulkanCompute::run(PipelineId pipeline, const std::vector<BufferId>& buffers,
                          const void* push, uint32_t push_bytes, uint32_t groups_x,
                          uint32_t groups_y, uint32_t groups_z) {
    // Every check before recording starts
    if (pipeline < 0 || size_t(pipeline) >= m_->pipelines.size())
        fail("VulkanCompute::run: no pipeline ", pipeline, " (", m_->pipelines.size(),
             " pipelines made)");
    const Impl::Pipeline& p = m_->pipelines[size_t(pipeline)];
    if (buffers.size() != size_t(p.num_buffers))
        fail("VulkanCompute::run: ", buffers.size(), " buffers for a pipeline of ",
             p.num_buffers);
    if (push_bytes != p.push_bytes || (push_bytes > 0 && !push))
        fail("VulkanCompute::run: ", push ? push_bytes : 0,
             " bytes of push constants for a pipeline of ", p.push_bytes);
    const VkPhysicalDeviceLimits& lim = m_->props.limits;
    const uint32_t groups[3] = {groups_x, groups_y, groups_z};
    for (int k = 0; k < 3; ++k)
        if (groups[k] > lim.maxComputeWorkGroupCount[k])
            fail("VulkanCompute::run: ", groups[k], " workgroups along ", "xyz"[k],
                 " (at most ", lim.maxComputeWorkGroupCount[k], " on '", m_->name, "')");
    std::vector<VkDescriptorBufferInfo> infos(buffers.size());
    for (size_t i = 0; i < buffers.size(); ++i) {
        const Impl::Buffer& b = m_->buffer(buffers[i], "run");
        if ((p.uniform_mask >> i) & 1u) {
            if (b.size > lim.maxUniformBufferRange)
                fail("VulkanCompute::run: buffer ", buffers[i], " at binding ", i,
                     " has ", b.size, " bytes; '", m_->name, "' binds at most ",
                     lim.maxUniformBufferRange, " as a uniform buffer");
        } else if (b.size > lim.maxStorageBufferRange) {
            fail("VulkanCompute::run: buffer ", buffers[i], " at binding ", i, " has ",
                 b.size, " bytes; '", m_->name, "' binds at most ",
                 lim.maxStorageBufferRange, " (maxStorageBufferRange)");
        }
        infos[i] = {b.buffer, 0, VK_WHOLE_SIZE};
    }

    // The descriptor set: the pool's only one, free again since the last run waited
    VkDevice device = m_->device;
    VkDescriptorSet set = VK_NULL_HANDLE;
    if (!buffers.empty()) {
        check(vkResetDescriptorPool(device, m_->descriptor_pool, 0),
              "vkResetDescriptorPool");
        VkDescriptorSetAllocateInfo ainfo{};
        ainfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
        ainfo.descriptorPool = m_->descriptor_pool;
        ainfo.descriptorSetCount = 1;
        ainfo.pSetLayouts = &p.set_layout;
        check(vkAllocateDescriptorSets(device, &ainfo, &set), "vkAllocateDescriptorSets");
        std::vector<VkWriteDescriptorSet> writes(buffers.size());
        for (size_t i = 0; i < buffers.size(); ++i) {
            writes[i] = {};
            writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
            writes[i].dstSet = set;
            writes[i].dstBinding = uint32_t(i);
            writes[i].descriptorCount = 1;
            writes[i].descriptorType = (p.uniform_mask >> i) & 1u
                                           ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER
                                           : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
            writes[i].pBufferInfo = &infos[i];
        }
        vkUpdateDescriptorSets(device, uint32_t(writes.size()), writes.data(), 0,
                               nullptr);
    }

    VkCommandBuffer cmd = m_->cmd;
    const bool timed = m_->query_pool != VK_NULL_HANDLE;
    m_->begin();
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipeline);
    if (set != VK_NULL_HANDLE)
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 1, &set,
                                0, nullptr);
    if (push_bytes > 0)
        vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes,
                           push);
    if (timed) {
        vkCmdResetQueryPool(cmd, m_->query_pool, 0, 2);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, m_->query_pool, 0);
    }
    vkCmdDispatch(cmd, groups_x, groups_y, groups_z);
    if (timed)
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, m_->query_pool, 1);
    const auto t0 = std::chrono::steady_clock::now();
    m_->submit_and_wait();
    const auto t1 = std::chrono::steady_clock::now();
    if (!timed) return std::chrono::duration<double>(t1 - t0).count();

    uint64_t ticks[2] = {0, 0};
    check(vkGetQueryPoolResults(device, m_->query_pool, 0, 2, sizeof ticks, ticks,
                                sizeof(uint64_t),
                                VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
          "vkGetQueryPoolResults");
    // Timestamps have timestamp_bits valid bits and may wrap around once
    const uint64_t mask =
        m_->timestamp_bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << m_->timestamp_bits) - 1;
    const uint64_t elapsed = (ticks[1] - ticks[0]) & mask;
    return double(elapsed) * double(lim.timestampPeriod) * 1e-9;
}

}  // namespace sss

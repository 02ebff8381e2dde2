// SPDX-License-Identifier: Apache-2.0
#pragma once
// How much memory a job needs, said before it is allocated: a map too large
// for the machine or the device is refused with the numbers instead of
// failing part way (or being killed by the kernel's OOM killer) with files
// half made. No OpenCL types here: the plugin includes it.
#include <cstdint>
#include <filesystem>
#include <string>

namespace relief::host {

class ComputeContext;

using Bytes = std::uint64_t;

// What this process may still allocate: the smallest of the machine's
// available memory (MemAvailable), the cgroup's limit less its use, and
// $RELIEF_MEMORY_LIMIT (size_setting_from_environment's units),
// which a farm sets to share a node between jobs. Throws Error for a
// malformed $RELIEF_MEMORY_LIMIT.
Bytes host_memory_available();

// What the cgroups (v2) named in `proc_cgroup` (/proc/self/cgroup) allow
// under `root` (/sys/fs/cgroup): for the process's own group and each one
// above it that has a limit (memory.max), the limit less what the group
// uses (memory.current), not counting the file pages the kernel can take
// back (memory.stat's inactive_file). Unlimited without any limit.
Bytes cgroup_available(const std::filesystem::path& proc_cgroup, const std::filesystem::path& root);

// "12.3 GB" (decimal units, as memory is sold), or with `binary` "11.5
// GiB" (powers of 1024, as RELIEF_MEMORY_LIMIT=10M is given).
std::string format_bytes(Bytes b, bool binary = false);

// "" when `need` bytes fit in host memory, else the refusal:
// "needs 48.0 GB of memory, this machine has 16.0 GB available", or where
// RELIEF_MEMORY_LIMIT is the bound, in its units: "needs 13.0 MiB of
// memory, RELIEF_MEMORY_LIMIT=10M allows 10.0 MiB".
std::string refuse_host(Bytes need);

// The device's memory: CL_DEVICE_GLOBAL_MEM_SIZE, and whether it is the
// host's own (a CPU device), where its buffers count against host memory.
struct DeviceMemory {
    Bytes total = 0;
    bool host_unified = false;
};
DeviceMemory device_memory(ComputeContext& ctx);

// Refuses a stage needing `device` bytes of device buffers at its peak and
// `host` bytes of host memory, taken when `device_at_host` of the device
// bytes are still held: throws Error naming `what` with the numbers when
// either does not fit. On a CPU device the buffers are host memory, so the
// two are added at the moment they meet. `made` of the device bytes are
// already allocated (no longer available).
void check_memory(ComputeContext& ctx, const std::string& what, Bytes device, Bytes host, Bytes made = 0,
                  Bytes device_at_host = ~Bytes(0));

}  // namespace relief::host

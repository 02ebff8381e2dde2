// SPDX-License-Identifier: Apache-2.0
#include "device/memory_budget.h"
#include "device/environment.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <unistd.h>

#include "errors.h"
#include "device/opencl_context.h"

namespace relief::host {

namespace fs = std::filesystem;

namespace {

constexpr Bytes kUnlimited = std::numeric_limits<Bytes>::max();

// RELIEF_MEMORY_LIMIT, its bytes 0 when unset.
SizeSetting limit_from_environment()
{
    return size_setting_from_environment("RELIEF_MEMORY_LIMIT");
}

// MemAvailable from /proc/meminfo (kB), else the free pages.
Bytes machine_available()
{
    std::ifstream meminfo("/proc/meminfo");
    std::string key;
    Bytes kb = 0;
    std::string unit;
    while (meminfo >> key >> kb >> unit)
        if (key == "MemAvailable:")
            return kb * 1024;
    const long pages = sysconf(_SC_AVPHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? Bytes(pages) * Bytes(page) : kUnlimited;
}

}  // namespace

Bytes cgroup_available(const fs::path& proc_cgroup, const fs::path& root)
{
    auto number = [](const fs::path& p) -> Bytes {
        std::ifstream f(p);
        std::string v;
        if (!(f >> v) || v == "max")
            return kUnlimited;
        return Bytes(std::strtoull(v.c_str(), nullptr, 10));
    };
    auto reclaimable = [](const fs::path& stat) -> Bytes {
        std::ifstream f(stat);
        std::string key;
        Bytes v = 0;
        while (f >> key >> v)
            if (key == "inactive_file")
                return v;
        return 0;
    };
    std::string own;  // "0::/user.slice/..." in /proc/self/cgroup
    {
        std::ifstream f(proc_cgroup);
        for (std::string line; std::getline(f, line);)
            if (line.rfind("0::", 0) == 0)
                own = line.substr(3);
    }
    Bytes available = kUnlimited;
    fs::path dir = (root / fs::path(own).relative_path()).lexically_normal();
    for (int depth = 0; depth < 64; ++depth) {
        const Bytes max = number(dir / "memory.max");
        if (max != kUnlimited) {
            const Bytes used = number(dir / "memory.current");
            const Bytes free_back = reclaimable(dir / "memory.stat");
            const Bytes held = used == kUnlimited ? 0 : used - std::min(used, free_back);
            available = std::min(available, held >= max ? 0 : max - held);
        }
        if (dir == root || dir == dir.parent_path() || dir.string().size() <= root.string().size())
            break;
        dir = dir.parent_path();
    }
    return available;
}

Bytes host_memory_available()
{
    Bytes a = std::min(machine_available(), cgroup_available("/proc/self/cgroup", "/sys/fs/cgroup"));
    if (const Bytes limit = limit_from_environment().bytes)
        a = std::min(a, limit);
    return a;
}

std::string format_bytes(Bytes b, bool binary)
{
    char text[64];
    const double v = double(b);
    const double k = binary ? 1024.0 : 1000.0;
    const char* units[] = {binary ? "KiB" : "kB", binary ? "MiB" : "MB", binary ? "GiB" : "GB",
                           binary ? "TiB" : "TB"};
    if (v < k * k) {
        std::snprintf(text, sizeof text, "%.0f %s", std::max(v / k, 1.0), units[0]);
        return text;
    }
    int u = 1;
    double scaled = v / (k * k);
    while (u < 3 && scaled >= k) {
        scaled /= k;
        ++u;
    }
    std::snprintf(text, sizeof text, "%.1f %s", scaled, units[u]);
    return text;
}

std::string refuse_host(Bytes need)
{
    const Bytes have = host_memory_available();
    if (need <= have)
        return "";
    // The limit in the units it was given: RELIEF_MEMORY_LIMIT=10M reads
    // 10.0 MiB, =10MB 10.0 MB.
    const SizeSetting limit = limit_from_environment();
    if (limit.bytes == have)
        return "needs " + format_bytes(need, limit.binary) + " of memory, RELIEF_MEMORY_LIMIT=" + limit.text +
               " allows " + format_bytes(have, limit.binary);
    return "needs " + format_bytes(need) + " of memory, this machine has " + format_bytes(have) +
           " available";
}

DeviceMemory device_memory(ComputeContext& ctx)
{
    auto& c = ctx.impl();
    DeviceMemory m;
    m.total = Bytes(c.device.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>());
    m.host_unified = c.device.getInfo<CL_DEVICE_HOST_UNIFIED_MEMORY>() != CL_FALSE ||
                     c.device.getInfo<CL_DEVICE_TYPE>() == CL_DEVICE_TYPE_CPU;
    return m;
}

void check_memory(ComputeContext& ctx, const std::string& what, Bytes device, Bytes host, Bytes made,
                  Bytes device_at_host)
{
    const DeviceMemory d = device_memory(ctx);
    if (device > d.total)
        throw Error(what + " needs " + format_bytes(device) + " of device memory, the device has " +
                    format_bytes(d.total));
    // A CPU device's buffers are host memory: the peak is the device's own,
    // or what it still holds when the host memory is taken, plus that.
    Bytes on_host = host;
    if (d.host_unified) {
        const Bytes peak = std::max(device, std::min(device_at_host, device) + host);
        on_host = peak - std::min(made, peak);
    }
    const std::string why = refuse_host(on_host);
    if (!why.empty())
        throw Error(what + " " + why);
}

}  // namespace relief::host

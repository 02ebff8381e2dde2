// SPDX-License-Identifier: Apache-2.0
#include "relief/devices.h"

#include <OpenImageIO/imageio.h>

#include <exception>

#include "device/compute_context.h"
#include "device/environment.h"
#include "error_state.h"
#include "io/colour.h"
#include "poisson/poisson_stage.h"
#include "device/setup_times.h"
#include "fft/vkfft_version.h"

namespace relief {

std::vector<DeviceDescription> list_devices()
{
    std::vector<DeviceDescription> out;
    try {
        for (const auto& d : host::list_devices())
            out.push_back({std::to_string(d.platform_index) + ":" + std::to_string(d.device_index),
                           d.platform, d.platform_version, d.name, d.is_gpu, d.has_fp64});
    } catch (const std::exception& e) {
        detail::set_error(e.what());
    }
    return out;
}

std::vector<std::string> component_versions()
{
    const int oiio = OIIO::openimageio_version();  // 20407: 2.4.7
    std::vector<std::string> lines = {"OpenImageIO " + std::to_string(oiio / 10000) + "." +
                                          std::to_string(oiio / 100 % 100) + "." + std::to_string(oiio % 100),
                                      "OpenColorIO " + detail::ocio_version(),
                                      "VkFFT " + host::vkfft_version()};
    try {
        int last = -1;
        for (const auto& d : host::list_devices())
            if (d.platform_index != last) {
                last = d.platform_index;
                lines.push_back("OpenCL platform " + std::to_string(d.platform_index) + ": " + d.platform +
                                " (" + d.platform_version + ")");
            }
    } catch (const std::exception& e) {
        lines.push_back(std::string("OpenCL: ") + e.what());
    }
    return lines;
}

SetupTimes setup_times()
{
    const host::SetupTimes t = host::setup_times();
    return {t.device, t.programs, t.plans, t.prepared};
}

void prepare(const std::string& device, int width, int height)
{
    host::Ahead ahead;
    try {
        // Not on a simulator, whose kernels run thousands of times slower
        // than a read: Oclgrind's checks keep their state per thread, and
        // crash when the context was made on another thread than the one
        // that then uses it; its LLVM crashes on two threads' programs too.
        if (host::choose_device(device).simulator)
            return;
        host::prepare_height(*host::ComputeContext::acquire(device), width, height);
    } catch (...) {
        // the operation meets the same problem and reports it
    }
}

std::string environment_problem()
{
    try {
        host::size_setting_from_environment("RELIEF_MEMORY_LIMIT");
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

}  // namespace relief

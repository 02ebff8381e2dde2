// SPDX-License-Identifier: Apache-2.0
#pragma once
// The VkFFT relief is built with (for --version), without OpenCL's types:
// the plugin asks it (fft_plan.cpp answers).
#include <string>

namespace relief::host {

// "1.2.26"
std::string vkfft_version();

}  // namespace relief::host

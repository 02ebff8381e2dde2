// SPDX-License-Identifier: Apache-2.0
#pragma once
// OpenCL sources from kernels/, embedded at build time.
#include <string>
#include <vector>

namespace relief::host {

struct EmbeddedSource {
    std::string name;  // file name in kernels/, e.g. "ddm.cl"
    std::string text;
};

const std::vector<EmbeddedSource>& embedded_kernel_sources();

// The text of kernels/<name>. When $RELIEF_KERNEL_DIR is set (kernel
// development), the file is read from that folder instead of the embedded copy.
std::string kernel_source(const std::string& name);

}  // namespace relief::host

// SPDX-License-Identifier: Apache-2.0
// What decides results besides the images and the modifiers: relief's
// version and the kernel sources it builds (relief::implementation_digest).
#include <string>
#include <vector>

#include "device/binary_cache.h"
#include "device/kernel_sources.h"
#include "relief/operations.h"
#include "relief/version.h"

namespace relief {

std::string implementation_digest()
{
    std::vector<std::string> parts = {version()};
    for (const host::EmbeddedSource& s : host::embedded_kernel_sources()) {
        parts.push_back(s.name);
        parts.push_back(host::kernel_source(s.name));
    }
    return host::BinaryCache::key(parts);
}

}  // namespace relief

// SPDX-License-Identifier: Apache-2.0
#pragma once
// The memory a height needs, checked before anything is allocated.
#include <cstdint>

#include "relief/height.h"

namespace relief::detail {

// Refuses, with the numbers, a w x h height under `options` (its boundary
// still auto or chosen) whose device and host memory do not fit, counting
// `extra_host` bytes the caller holds besides (height_udim()'s canvas).
// Throws relief's memory error.
void check_height_memory(const HeightOptions& options, int w, int h, std::uint64_t extra_host);

}  // namespace relief::detail

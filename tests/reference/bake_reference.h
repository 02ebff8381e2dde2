// SPDX-License-Identifier: Apache-2.0
#pragma once
// Golden model of the bake gather: the texture at u + c(u), bilinear or
// Catmull-Rom bicubic, in double; reads wrap along a periodic axis and clamp
// along the other.
#include <vector>

namespace relief::reference {

std::vector<double> bake_gather(const std::vector<double>& src, int w, int h, int nch,
                                const std::vector<double>& offsets, bool periodic_x, bool periodic_y,
                                bool bicubic);

}  // namespace relief::reference

// SPDX-License-Identifier: Apache-2.0
#pragma once
// Golden model of the bake gather: the texture at u + c(u), bilinear or
// Catmull-Rom bicubic, in double.
#include <vector>

namespace relief::reference {

std::vector<double> bake_gather(const std::vector<double>& src, int w, int h, int nch,
                                const std::vector<double>& offsets, bool periodic, bool bicubic);

}  // namespace relief::reference

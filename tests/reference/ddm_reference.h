// SPDX-License-Identifier: Apache-2.0
#pragma once
// Golden model of the DDM derivation (docs/design.md §4.1), plain C++ in double.
#include <cstdint>
#include <vector>

namespace relief::reference {

struct DdmResult {
    std::vector<double> slopes;  // gx, gy per texel
    std::int64_t invalid = 0;
    std::int64_t clamped = 0;
};

// values: channels (2 or 3) per texel as stored; decoded = v * scale + bias,
// and decoded x, y with |value| <= zero_band are 0. green_to_row: -1 OpenGL,
// +1 DirectX.
DdmResult ddm(const std::vector<float>& values, int channels, double scale, double bias, double green_to_row,
              double max_angle_deg, double zero_band = 0.0);

// RMS per cell of the curl of a slope field (cells between texel centres).
double curl_rms(const std::vector<double>& slopes, int width, int height);

}  // namespace relief::reference

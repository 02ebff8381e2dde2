// SPDX-License-Identifier: Apache-2.0
#pragma once
// Small host-side operations on result fields.
#include <cstddef>

namespace relief::host {

// Subtracts the mean, summed in double in a fixed order (deterministic
// whatever the device's thread count).
inline void remove_mean(float* v, std::size_t n)
{
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i)
        sum += v[i];
    const float mean = float(sum / double(n));
    for (std::size_t i = 0; i < n; ++i)
        v[i] -= mean;
}

}  // namespace relief::host

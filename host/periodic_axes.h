// SPDX-License-Identifier: Apache-2.0
#pragma once
// Which axes of a texture wrap (it tiles along them), for the stages whose
// boundary is a choice per axis: distortion correction and the bake.

namespace relief::host {

// `Periodic(true)` is both axes, `Periodic(true, false)` along x only.
struct Periodic {
    bool x = true, y = true;
    constexpr Periodic(bool both = true) : x(both), y(both) {}
    constexpr Periodic(bool along_x, bool along_y) : x(along_x), y(along_y) {}
    // The kernels' `periodic` argument: bit 0 x, bit 1 y.
    int bits() const { return int(x) | int(y) << 1; }
};

}  // namespace relief::host

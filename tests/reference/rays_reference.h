// SPDX-License-Identifier: Apache-2.0
#pragma once
// Golden model of radial ray integration (docs/design.md §4.2), plain C++ in
// double. It walks every ray of every texel on its own, finding the texels
// crossed from the sorted grid-line crossings (not from per-direction tables
// as the kernel does), so the two share no traversal code.
#include <vector>

namespace relief::reference {

struct RaySettings {
    int rays = 32;
    double radius = 64.0;
    double phase = 0.5;
    bool periodic = true;
    // Rational directions (docs/design.md §4.3): the primitive integer step closest
    // in angle, |a|, |b| <= max(2, ceil(rays/4)); the walk is split at every
    // period boundary t = m*|(a, b)|.
    bool rational = false;
};

// The rational step chosen for direction j (independent of the host's).
void rational_step(int j, const RaySettings& settings, int& a, int& b);

// slopes: gx, gy per texel (row-major). Returns the zero-mean displacement.
std::vector<double> rays(const std::vector<double>& slopes, int width, int height,
                         const RaySettings& settings);

}  // namespace relief::reference

// SPDX-License-Identifier: Apache-2.0
#pragma once
// Golden model of the checks of a height (docs/design.md §9), in double: its normal
// map, the round trip against slopes, and per-patch tessellation errors.
#include <vector>

namespace relief::reference {

// 3 values per texel: normalize(-s gx, -s gy, 1) with gx, gy by central
// differences (one-sided at the edges across which the map is free,
// wrapping along a periodic axis), the row component as stored (-n_y for
// OpenGL, +n_y DirectX).
std::vector<double> height_normals(const std::vector<double>& h, int w, int ht, bool periodic_x,
                                   bool periodic_y, double scale, bool directx);
inline std::vector<double> height_normals(const std::vector<double>& h, int w, int ht, bool periodic,
                                          double scale, bool directx)
{
    return height_normals(h, w, ht, periodic, periodic, scale, directx);
}

struct RoundTrip {
    double mean = 0.0, p95 = 0.0, max = 0.0;  // degrees
    double residual_share = 0.0;
};

// g: 2 values per texel (gx, gy). p95: the nearest-rank 95th percentile.
RoundTrip round_trip(const std::vector<double>& g, const std::vector<double>& h, int w, int ht,
                     bool periodic_x, bool periodic_y);
inline RoundTrip round_trip(const std::vector<double>& g, const std::vector<double>& h, int w, int ht,
                            bool periodic)
{
    return round_trip(g, h, w, ht, periodic, periodic);
}

// Per patch (row-major) and level L = 1..64: the largest |surface - s h| at
// the patch's texel centres, the surface being the patch split into L x L
// quads (diagonal away from the patch centre), vertices bilinear in s h;
// 0 at level 1 for a flat patch (all its texels equal).
std::vector<double> tessellation_errors(const std::vector<double>& h, int w, int ht, int patch, double scale);

// The height of the bilinear surface at (x, y) (texel (i, j) at (i + .5, j + .5), clamped).
double bilinear(const std::vector<double>& h, int w, int ht, double x, double y);

}  // namespace relief::reference

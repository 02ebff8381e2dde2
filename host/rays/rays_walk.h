// SPDX-License-Identifier: Apache-2.0
#pragma once
// Per-direction walk tables for radial ray integration (docs/design.md §4.2).
//
// A ray from a texel centre in direction d crosses a sequence of texels; the
// sequence (as offsets from the origin texel) and the segment lengths are the
// same for every origin, so each direction is walked once, here, in double.
#include <vector>

namespace relief::host {

struct RaySegment {
    int ox = 0, oy = 0;  // texel offset from the ray's origin texel
    double t_in = 0.0;   // distance along the ray where the segment starts
    double t_out = 0.0;  // ... and ends (texel units)
    double ext_x = 0.0;  // (ext_x, ext_y) = d * (t_out - t_in)
    double ext_y = 0.0;
    // Area weight (t_out - t_in) * t_mid; 0 for the origin texel, which is
    // excluded from its own mean.
    double weight = 0.0;
};

// Walks the ray at `angle` radians (x right, y down) from the centre of texel
// (0, 0) for `radius` texels. Segment 0 is the origin texel. Segments of zero
// length (the ray grazing a texel corner) are dropped.
std::vector<RaySegment> walk_ray(double angle, double radius);

enum class DirectionSet { Exact, Rational };

// Ray angles: Exact gives 2*pi*(j + phase)/rays, j = 0..rays-1.
std::vector<double> ray_angles(int rays, double phase, DirectionSet set);

// A rational direction (docs/design.md §4.3): the primitive integer step (a, b);
// the ray through a texel centre passes through the centre of the texel
// (a, b) further on after one period of length |(a, b)|.
struct RationalDirection {
    int a = 1, b = 0;
    double length() const;
    double angle() const;
};

// The largest |a|, |b| a rational direction may use for `rays` directions:
// max(2, ceil(rays / 4)). Bigger steps fit the uniform angles better but
// cost more stencil work per texel (the fast kernel's cost grows with
// |a| + |b|, not with the radius).
int rational_step_limit(int rays);

// For each j, the primitive (a, b) with max(|a|, |b|) <= the step limit
// closest in angle to 2*pi*(j + phase)/rays (ties: the shorter vector, then
// the smaller (b, a)). O(rays log rays), by continued fractions.
std::vector<RationalDirection> rational_directions(int rays, double phase);

// The same by searching every candidate (O(rays^3)): the definition, for tests.
std::vector<RationalDirection> rational_directions_by_search(int rays, double phase);

// Quadrature weights of a direction set on the circle: each direction counts
// by half the angle to its two neighbours, normalised to a mean of 1
// (uniform angles: all 1). Rational steps sit unevenly; weighting them by
// angle keeps the ray average an average over the disk.
std::vector<double> angular_weights(const std::vector<double>& angles);

// The walk of one rational ray from the origin texel's centre to distance
// `radius`, split at every period boundary t = m*L: the texel at each chain
// point p + m*(a, b) contributes two half-segments, one to each period.
// Segment 0 is the origin's first half (weight 0).
std::vector<RaySegment> walk_rational_ray(const RationalDirection& d, double radius);

}  // namespace relief::host

#include "ray_walk.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace relief::host {

std::vector<RaySegment> walk_ray(double angle, double radius)
{
    // Amanatides–Woo traversal. Texel (i, j) covers [i-0.5, i+0.5] x [j-0.5, j+0.5].
    const double dx = std::cos(angle), dy = std::sin(angle);
    const double inf = std::numeric_limits<double>::infinity();
    // Directions within this of an axis are treated as exactly on it, so the
    // ray does not zig-zag through texels it only touches at a corner.
    const double eps = 1e-12;
    const int step_x = dx > eps ? 1 : (dx < -eps ? -1 : 0);
    const int step_y = dy > eps ? 1 : (dy < -eps ? -1 : 0);
    const double delta_x = step_x ? 1.0 / std::abs(dx) : inf;
    const double delta_y = step_y ? 1.0 / std::abs(dy) : inf;
    double next_x = step_x ? 0.5 * delta_x : inf;  // t of the next vertical texel edge
    double next_y = step_y ? 0.5 * delta_y : inf;

    std::vector<RaySegment> segs;
    int ix = 0, iy = 0;
    double t = 0.0;
    while (t < radius) {
        double t_out = std::min({next_x, next_y, radius});
        if (t_out > t) {
            RaySegment s;
            s.ox = ix;
            s.oy = iy;
            s.t_in = t;
            s.t_out = t_out;
            s.ext_x = dx * (t_out - t);
            s.ext_y = dy * (t_out - t);
            s.weight = segs.empty() ? 0.0 : (t_out - t) * 0.5 * (t + t_out);
            segs.push_back(s);
        }
        t = t_out;
        if (t >= radius)
            break;
        // Through a corner both coordinates change at once.
        const bool cross_x = next_x <= next_y + 1e-12 * next_y;
        const bool cross_y = next_y <= next_x + 1e-12 * next_x;
        if (cross_x) {
            ix += step_x;
            next_x += delta_x;
        }
        if (cross_y) {
            iy += step_y;
            next_y += delta_y;
        }
    }
    return segs;
}

std::vector<double> ray_angles(int rays, double phase, DirectionSet)
{
    std::vector<double> a(rays);
    for (int j = 0; j < rays; ++j)
        a[j] = 2.0 * M_PI * (j + phase) / rays;
    return a;
}

} // namespace relief::host

// SPDX-License-Identifier: Apache-2.0
#include "rays/rays_walk.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

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

std::vector<double> ray_angles(int rays, double phase, DirectionSet set)
{
    std::vector<double> a(rays);
    if (set == DirectionSet::Rational) {
        auto dirs = rational_directions(rays, phase);
        for (int j = 0; j < rays; ++j)
            a[j] = dirs[j].angle();
        return a;
    }
    for (int j = 0; j < rays; ++j)
        a[j] = 2.0 * M_PI * (j + phase) / rays;
    return a;
}

double RationalDirection::length() const
{
    return std::hypot(double(a), double(b));
}

double RationalDirection::angle() const
{
    return std::atan2(double(b), double(a));
}

int rational_step_limit(int rays)
{
    return std::max(2, (rays + 3) / 4);
}

namespace {

// Whether candidate c fits `target` better than `best`: a smaller angular
// error, then (within 1e-12) a shorter vector, then the smaller (b, a).
bool better_direction(const RationalDirection& c, double err, const RationalDirection& best, double best_err)
{
    if (err < best_err - 1e-12)
        return true;
    if (err > best_err + 1e-12)
        return false;
    if (c.length() != best.length())
        return c.length() < best.length();
    return c.b != best.b ? c.b < best.b : c.a < best.a;
}

double angle_error(const RationalDirection& c, double target)
{
    return std::abs(std::remainder(c.angle() - target, 2.0 * M_PI));
}

// The primitive directions with max(|a|, |b|) <= limit nearest in angle to
// `target`: within its octant the angle grows with the slope t = minor/major
// in [0, 1], so they are the two neighbours of t among the fractions with
// denominators <= limit (a Farey sequence), found from t's continued
// fraction in O(log limit) (as Python's Fraction.limit_denominator).
RationalDirection nearest_direction(double target, int limit)
{
    const double cx = std::cos(target), cy = std::sin(target);
    const bool steep = std::abs(cy) > std::abs(cx);
    const double major = steep ? std::abs(cy) : std::abs(cx);
    const double t = steep ? std::abs(cx) / major : std::abs(cy) / major;
    // Convergents p0/q0, p1/q1 of t with denominators <= limit.
    long long p0 = 0, q0 = 1, p1 = 1, q1 = 0;
    double x = t;
    for (int guard = 0; guard < 64; ++guard) {
        const double whole = std::floor(x);
        const long long a = (long long)whole;
        const long long q2 = q0 + a * q1;
        if (q2 > limit)
            break;
        const long long p2 = p0 + a * p1;
        p0 = p1;
        q0 = q1;
        p1 = p2;
        q1 = q2;
        const double rest = x - whole;
        if (rest <= 0.0)
            break;
        x = 1.0 / rest;
    }
    // The semiconvergent below the limit and the last convergent bracket t.
    const long long k = q1 > 0 ? (limit - q0) / q1 : 0;
    const long long fractions[2][2] = {{p0 + k * p1, q0 + k * q1}, {p1, q1}};
    RationalDirection best;
    double best_err = std::numeric_limits<double>::infinity();
    for (const auto& f : fractions) {
        const long long num = f[0], den = f[1];
        if (den < 1 || den > limit || num > den || std::gcd(num, den) != 1)
            continue;
        // Back from the first octant: minor/major to (a, b) with signs.
        const int minor = int(num), maj = int(den);
        RationalDirection c;
        c.a = (steep ? minor : maj) * (cx < 0 ? -1 : 1);
        c.b = (steep ? maj : minor) * (cy < 0 ? -1 : 1);
        const double err = angle_error(c, target);
        if (better_direction(c, err, best, best_err)) {
            best = c;
            best_err = err;
        }
    }
    return best;
}

}  // namespace

std::vector<RationalDirection> rational_directions(int rays, double phase)
{
    const int limit = rational_step_limit(rays);
    std::vector<RationalDirection> out;
    out.reserve(rays);
    for (int j = 0; j < rays; ++j)
        out.push_back(nearest_direction(2.0 * M_PI * (j + phase) / rays, limit));
    return out;
}

std::vector<RationalDirection> rational_directions_by_search(int rays, double phase)
{
    const int limit = rational_step_limit(rays);
    std::vector<RationalDirection> candidates;
    for (int b = -limit; b <= limit; ++b)
        for (int a = -limit; a <= limit; ++a)
            if ((a || b) && std::gcd(a, b) == 1)
                candidates.push_back({a, b});
    std::vector<RationalDirection> out;
    for (int j = 0; j < rays; ++j) {
        const double target = 2.0 * M_PI * (j + phase) / rays;
        RationalDirection best;
        double best_err = std::numeric_limits<double>::infinity();
        for (const auto& c : candidates) {
            const double err = angle_error(c, target);
            if (better_direction(c, err, best, best_err)) {
                best = c;
                best_err = err;
            }
        }
        out.push_back(best);
    }
    return out;
}

std::vector<double> angular_weights(const std::vector<double>& angles)
{
    const std::size_t n = angles.size();
    std::vector<double> w(n, 1.0);
    if (n < 2)
        return w;
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    auto wrapped = [](double a) {
        a = std::fmod(a, 2.0 * M_PI);
        return a < 0 ? a + 2.0 * M_PI : a;
    };
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return wrapped(angles[a]) < wrapped(angles[b]); });
    for (std::size_t k = 0; k < n; ++k) {
        const double prev = wrapped(angles[order[(k + n - 1) % n]]);
        const double next = wrapped(angles[order[(k + 1) % n]]);
        double span = next - prev;
        if (span <= 0)
            span += 2.0 * M_PI;
        w[order[k]] = 0.5 * span * double(n) / (2.0 * M_PI);
    }
    return w;
}

std::vector<RaySegment> walk_rational_ray(const RationalDirection& d, double radius)
{
    const double L = d.length();
    const std::vector<RaySegment> period = walk_ray(d.angle(), L);
    std::vector<RaySegment> out;
    for (int m = 0; m * L < radius - 1e-9 * L; ++m) {
        const double t0 = m * L;
        const double span = std::min(L, radius - t0);
        const std::vector<RaySegment> part = span < L ? walk_ray(d.angle(), span) : period;
        for (RaySegment s : part) {
            s.ox += m * d.a;
            s.oy += m * d.b;
            s.t_in += t0;
            s.t_out += t0;
            s.weight = out.empty() ? 0.0 : (s.t_out - s.t_in) * 0.5 * (s.t_in + s.t_out);
            out.push_back(s);
        }
    }
    return out;
}

}  // namespace relief::host

// SPDX-License-Identifier: Apache-2.0
#include "correct/correct_grid.h"

#include <algorithm>
#include <cmath>

#include "device/cancel.h"

namespace relief::host {

NodeGrid::NodeGrid(int texels_w, int texels_h, bool corner_nodes, Periodic periodic_axes)
    : width(texels_w), height(texels_h), corner(corner_nodes), periodic(periodic_axes)
{
    nx = width + (corner && !periodic.x ? 1 : 0);
    ny = height + (corner && !periodic.y ? 1 : 0);
}

namespace {

// Weights of the area resampling of n samples to m (m <= n): output k
// covers [k n/m, (k+1) n/m) of the input.
struct Span {
    int first = 0;
    std::vector<double> weight;
};

std::vector<Span> area_spans(int n, int m)
{
    std::vector<Span> spans(m);
    const double ratio = double(n) / m;
    for (int k = 0; k < m; ++k) {
        const double a = k * ratio, b = (k + 1) * ratio;
        Span& s = spans[k];
        s.first = int(std::floor(a));
        for (int i = s.first; i < n && i < b; ++i) {
            const double overlap = std::min(b, i + 1.0) - std::max(a, double(i));
            s.weight.push_back(std::max(0.0, overlap) / ratio);
        }
    }
    return spans;
}

int wrap(int v, int n)
{
    v %= n;
    return v < 0 ? v + n : v;
}

}  // namespace

std::vector<float> area_downsample(const std::vector<float>& src, int w, int h, int w2, int h2)
{
    const auto sx = area_spans(w, w2), sy = area_spans(h, h2);
    std::vector<double> rows(std::size_t(w) * h2, 0.0);
    for (int y2 = 0; y2 < h2; ++y2)
        for (std::size_t k = 0; k < sy[y2].weight.size(); ++k) {
            const int y = sy[y2].first + int(k);
            const double wt = sy[y2].weight[k];
            for (int x = 0; x < w; ++x)
                rows[std::size_t(y2) * w + x] += wt * src[std::size_t(y) * w + x];
        }
    std::vector<float> out(std::size_t(w2) * h2);
    for (int y2 = 0; y2 < h2; ++y2)
        for (int x2 = 0; x2 < w2; ++x2) {
            double v = 0.0;
            for (std::size_t k = 0; k < sx[x2].weight.size(); ++k)
                v += sx[x2].weight[k] * rows[std::size_t(y2) * w + sx[x2].first + int(k)];
            out[std::size_t(y2) * w2 + x2] = float(v);
        }
    return out;
}

std::vector<float> node_values(const std::vector<float>& texels, const NodeGrid& g)
{
    if (!g.corner)
        return texels;
    std::vector<float> out(std::size_t(g.nx) * g.ny);
    auto at = [&](int x, int y) {
        x = g.periodic.x ? wrap(x, g.width) : std::clamp(x, 0, g.width - 1);
        y = g.periodic.y ? wrap(y, g.height) : std::clamp(y, 0, g.height - 1);
        return double(texels[std::size_t(y) * g.width + x]);
    };
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i)
            out[std::size_t(j) * g.nx + i] =
                float(0.25 * (at(i - 1, j - 1) + at(i, j - 1) + at(i - 1, j) + at(i, j)));
    return out;
}

std::vector<float> upsample_offsets(const std::vector<float>& coarse, const NodeGrid& from,
                                    const NodeGrid& to)
{
    std::vector<float> out(2 * std::size_t(to.nx) * to.ny, 0.0f);
    auto index = [&](double pos, int n, int texels, bool periodic, int& i0, int& i1, double& f) {
        // Node coordinate of a texture position on the coarse grid.
        const double x = from.corner ? pos * texels : pos * texels - 0.5;
        const double fl = std::floor(x);
        f = x - fl;
        i0 = int(fl);
        i1 = i0 + 1;
        if (periodic) {
            i0 = wrap(i0, n);
            i1 = wrap(i1, n);
        } else {
            if (i0 < 0) {
                i0 = i1 = 0;
                f = 0.0;
            } else if (i1 >= n) {
                i0 = i1 = n - 1;
                f = 0.0;
            }
        }
    };
    for (int j = 0; j < to.ny; ++j) {
        int y0, y1;
        double fy;
        index(to.v(j), from.ny, from.height, from.periodic.y, y0, y1, fy);
        for (int i = 0; i < to.nx; ++i) {
            const std::size_t o = 2 * (std::size_t(j) * to.nx + i);
            if ((!to.periodic.x && (i == 0 || i == to.nx - 1)) ||
                (!to.periodic.y && (j == 0 || j == to.ny - 1)))
                continue;
            int x0, x1;
            double fx;
            index(to.u(i), from.nx, from.width, from.periodic.x, x0, x1, fx);
            for (int ch = 0; ch < 2; ++ch) {
                auto at = [&](int x, int y) {
                    return double(coarse[2 * (std::size_t(y) * from.nx + x) + ch]);
                };
                out[o + ch] = float((1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) +
                                    fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1)));
            }
        }
    }
    return out;
}

std::vector<float> texel_offsets(const std::vector<float>& node_offsets, const NodeGrid& g)
{
    if (!g.corner)
        return node_offsets;
    std::vector<float> out(2 * std::size_t(g.width) * g.height);
    for (int y = 0; y < g.height; ++y)
        for (int x = 0; x < g.width; ++x)
            for (int ch = 0; ch < 2; ++ch) {
                auto at = [&](int i, int j) {
                    if (g.periodic.x)
                        i = wrap(i, g.nx);
                    if (g.periodic.y)
                        j = wrap(j, g.ny);
                    return double(node_offsets[2 * (std::size_t(j) * g.nx + i) + ch]);
                };
                out[2 * (std::size_t(y) * g.width + x) + ch] =
                    float(0.25 * (at(x, y) + at(x + 1, y) + at(x, y + 1) + at(x + 1, y + 1)));
            }
    return out;
}

namespace {

// How far around the flipped triangles unflip_mesh() reaches when stuck.
constexpr int kMaxRing = 3;

// The node at (i, j), wrapped along a periodic axis; -1 off a fixed one.
long long node_at(const NodeGrid& g, int i, int j)
{
    if (g.periodic.x)
        i = wrap(i, g.nx);
    if (g.periodic.y)
        j = wrap(j, g.ny);
    if (i < 0 || j < 0 || i >= g.nx || j >= g.ny)
        return -1;
    return (long long)j * g.nx + i;
}

// Twice the texture area of node p's triangle t (0 or 1), if it exists.
bool triangle_area(const std::vector<float>& c, const NodeGrid& g, int i, int j, int t, double& area2)
{
    static const int kEdges[2][2][2] = {{{1, 0}, {1, -1}}, {{1, -1}, {0, -1}}};
    const long long p = node_at(g, i, j);
    const int* da = kEdges[t][0];
    const int* db = kEdges[t][1];
    const long long a = node_at(g, i + da[0], j + da[1]), b = node_at(g, i + db[0], j + db[1]);
    if (p < 0 || a < 0 || b < 0)
        return false;
    const double e1x = da[0] + double(c[2 * a]) - c[2 * p], e1y = da[1] + double(c[2 * a + 1]) - c[2 * p + 1];
    const double e2x = db[0] + double(c[2 * b]) - c[2 * p], e2y = db[1] + double(c[2 * b + 1]) - c[2 * p + 1];
    area2 = e1y * e2x - e1x * e2y;  // y down: positive unless flipped
    return true;
}

// How flipped the triangles that have node (i, j) as a corner are (those
// owned by it and by (i-1, j), (i-1, j+1), (i, j+1)): their count, then
// the sum of their negative areas (less is better).
std::pair<int, double> flips_around(const std::vector<float>& c, const NodeGrid& g, int i, int j)
{
    std::pair<int, double> f{0, 0.0};
    for (const auto& [di, dj] : {std::pair{0, 0}, {-1, 0}, {-1, 1}, {0, 1}})
        for (int t = 0; t < 2; ++t) {
            double a2;
            if (triangle_area(c, g, i + di, j + dj, t, a2) && !(a2 > 0.0)) {
                ++f.first;
                f.second -= a2;
            }
        }
    return f;
}

// The offset of node (i, j) that leaves the triangles around it the
// largest least distance from flipping (each triangle's area is affine in
// it: the point deepest inside the half-planes), or false if none is
// inside them all. A 2-D linear programme over at most six half-planes,
// solved by its vertices (three constraints active).
bool deepest_offset(std::vector<float>& c, const NodeGrid& g, int i, int j, float& ox, float& oy)
{
    const long long q = node_at(g, i, j);
    const float x0 = c[2 * q], y0 = c[2 * q + 1];
    struct HalfPlane {
        double a0, gx, gy;  // area2 = a0 + gx dx + gy dy, (dx, dy) from (x0, y0)
    };
    std::vector<HalfPlane> planes;
    for (const auto& [di, dj] : {std::pair{0, 0}, {-1, 0}, {-1, 1}, {0, 1}})
        for (int t = 0; t < 2; ++t) {
            double a0, ax, ay;
            if (!triangle_area(c, g, i + di, j + dj, t, a0))
                continue;
            c[2 * q] = x0 + 1.0f;
            triangle_area(c, g, i + di, j + dj, t, ax);
            c[2 * q] = x0;
            c[2 * q + 1] = y0 + 1.0f;
            triangle_area(c, g, i + di, j + dj, t, ay);
            c[2 * q + 1] = y0;
            const double gx = ax - a0, gy = ay - a0, n = std::hypot(gx, gy);
            if (n > 0.0)
                planes.push_back({a0 / n, gx / n, gy / n});
        }
    // max m subject to a0 + gx dx + gy dy >= m for every plane.
    double best = 0.0;
    bool found = false;
    const std::size_t n = planes.size();
    for (std::size_t a = 0; a < n; ++a)
        for (std::size_t b = a + 1; b < n; ++b)
            for (std::size_t d = b + 1; d < n; ++d) {
                // gx dx + gy dy - m = -a0 for the three.
                const HalfPlane* P[3] = {&planes[a], &planes[b], &planes[d]};
                double M[3][4];
                for (int r = 0; r < 3; ++r) {
                    M[r][0] = P[r]->gx;
                    M[r][1] = P[r]->gy;
                    M[r][2] = -1.0;
                    M[r][3] = -P[r]->a0;
                }
                // Gaussian elimination with partial pivoting.
                bool singular = false;
                for (int col = 0; col < 3 && !singular; ++col) {
                    int piv = col;
                    for (int r = col + 1; r < 3; ++r)
                        if (std::abs(M[r][col]) > std::abs(M[piv][col]))
                            piv = r;
                    if (std::abs(M[piv][col]) < 1e-12) {
                        singular = true;
                        break;
                    }
                    std::swap(M[col], M[piv]);
                    for (int r = 0; r < 3; ++r)
                        if (r != col) {
                            const double f = M[r][col] / M[col][col];
                            for (int k = col; k < 4; ++k)
                                M[r][k] -= f * M[col][k];
                        }
                }
                if (singular)
                    continue;
                const double dx = M[0][3] / M[0][0], dy = M[1][3] / M[1][1], m = M[2][3] / M[2][2];
                bool feasible = m > best;
                for (const HalfPlane& h : planes)
                    feasible = feasible && h.a0 + h.gx * dx + h.gy * dy >= m - 1e-9;
                if (feasible && std::isfinite(dx) && std::isfinite(dy)) {
                    best = m;
                    found = true;
                    ox = float(x0 + dx);
                    oy = float(y0 + dy);
                }
            }
    return found;
}

}  // namespace

std::vector<long long> flipped_triangles(const std::vector<float>& c, const NodeGrid& g)
{
    std::vector<long long> out;
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i)
            for (int t = 0; t < 2; ++t) {
                double a2;
                if (triangle_area(c, g, i, j, t, a2) && !(a2 > 0.0))
                    out.push_back(2 * ((long long)j * g.nx + i) + t);
            }
    return out;
}

int unflip_mesh(std::vector<float>& c, const NodeGrid& g, int rounds)
{
    static const int kNeighbours[6][2] = {{0, -1}, {1, -1}, {1, 0}, {0, 1}, {-1, 1}, {-1, 0}};
    static const int kCorners[2][3][2] = {{{0, 0}, {1, 0}, {1, -1}}, {{0, 0}, {1, -1}, {0, -1}}};
    const auto movable = [&](long long q) {
        const int i = int(q % g.nx), j = int(q / g.nx);
        return (g.periodic.x || (i > 0 && i < g.nx - 1)) && (g.periodic.y || (j > 0 && j < g.ny - 1));
    };
    int moves = 0, ring = 0;
    std::size_t flipped_before = 0;
    for (int round = 0; round < rounds; ++round) {
        stop_if_cancelled();  // (each round passes over the whole mesh: 20 of them took 0.3 s at 1024^2)
        const std::vector<long long> flipped = flipped_triangles(c, g);
        if (flipped.empty())
            break;
        // Where a round left as many flipped, the next also moves the
        // nodes around them, one ring further each time.
        ring = round > 0 && flipped.size() >= flipped_before ? ring + 1 : 0;
        flipped_before = flipped.size();
        std::vector<long long> nodes, core;
        for (long long f : flipped) {
            const int i = int((f / 2) % g.nx), j = int((f / 2) / g.nx);
            for (const auto& d : kCorners[f % 2]) {
                core.push_back(node_at(g, i + d[0], j + d[1]));
                for (int dj = -ring; dj <= ring; ++dj)
                    for (int di = -ring; di <= ring; ++di) {
                        const long long q = node_at(g, i + d[0] + di, j + d[1] + dj);
                        if (q >= 0 && movable(q))
                            nodes.push_back(q);
                    }
            }
        }
        for (std::vector<long long>* v : {&nodes, &core}) {
            std::sort(v->begin(), v->end());
            v->erase(std::unique(v->begin(), v->end()), v->end());
        }
        bool moved = false;
        for (long long q : nodes) {
            const int i = int(q % g.nx), j = int(q / g.nx);
            double mx = 0.0, my = 0.0;
            int count = 0;
            for (const auto& d : kNeighbours) {
                const long long r = node_at(g, i + d[0], j + d[1]);
                if (r >= 0) {
                    mx += c[2 * r];
                    my += c[2 * r + 1];
                    ++count;
                }
            }
            mx /= count;
            my /= count;
            const float x0 = c[2 * q], y0 = c[2 * q + 1];
            std::pair<int, double> best = flips_around(c, g, i, j);
            float bx = x0, by = y0;
            // Towards the neighbours' mean, then towards no offset at all.
            for (int k = 0; k < 8; ++k) {
                const double t = 0.25 * (k % 4 + 1), tx = k < 4 ? mx : 0.0, ty = k < 4 ? my : 0.0;
                c[2 * q] = float(x0 + t * (tx - x0));
                c[2 * q + 1] = float(y0 + t * (ty - y0));
                const std::pair<int, double> f = flips_around(c, g, i, j);
                if (f < best) {
                    best = f;
                    bx = c[2 * q];
                    by = c[2 * q + 1];
                }
            }
            // The point deepest inside the fan's half-planes, where there
            // is one. A node around the flipped triangles' corners goes
            // there while that flips nothing: it opens room for them.
            const bool around = !std::binary_search(core.begin(), core.end(), q);
            float dx, dy;
            if ((best.first > 0 || around) && deepest_offset(c, g, i, j, dx, dy)) {
                c[2 * q] = dx;
                c[2 * q + 1] = dy;
                const std::pair<int, double> f = flips_around(c, g, i, j);
                if (f < best || (around && f <= best)) {
                    best = f;
                    bx = dx;
                    by = dy;
                }
            }
            c[2 * q] = bx;
            c[2 * q + 1] = by;
            if (bx != x0 || by != y0) {
                moved = true;
                ++moves;
            }
        }
        if (!moved && ring >= kMaxRing)
            break;
    }
    return moves;
}

std::vector<std::pair<int, int>> pyramid_sizes(int w, int h, int levels, int min_side)
{
    std::vector<std::pair<int, int>> sizes{{w, h}};
    while (levels <= 0 || int(sizes.size()) < levels) {
        const int w2 = (sizes.back().first + 1) / 2, h2 = (sizes.back().second + 1) / 2;
        if (std::min(w2, h2) < min_side || (w2 == sizes.back().first && h2 == sizes.back().second))
            break;
        sizes.push_back({w2, h2});
    }
    return sizes;
}

}  // namespace relief::host

// SPDX-License-Identifier: Apache-2.0
#include "correct_grid.h"

#include <algorithm>
#include <cmath>

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

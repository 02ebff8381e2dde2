// SPDX-License-Identifier: Apache-2.0
#include "reference/bake_reference.h"

#include <algorithm>
#include <cmath>

namespace relief::reference {

std::vector<double> bake_gather(const std::vector<double>& src, int w, int h, int nch,
                                const std::vector<double>& offsets, bool periodic_x, bool periodic_y,
                                bool bicubic)
{
    auto idx = [&](int v, int n, bool periodic) {
        if (periodic)
            return ((v % n) + n) % n;
        return std::clamp(v, 0, n - 1);
    };
    auto cubic = [](double t) {  // Catmull-Rom kernel
        t = std::abs(t);
        if (t < 1)
            return 1.5 * t * t * t - 2.5 * t * t + 1.0;
        if (t < 2)
            return -0.5 * t * t * t + 2.5 * t * t - 4.0 * t + 2.0;
        return 0.0;
    };
    std::vector<double> out(std::size_t(w) * h * nch);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const std::size_t p = std::size_t(j) * w + i;
            const double x = i + offsets[2 * p] * w, y = j + offsets[2 * p + 1] * h;
            const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
            for (int ch = 0; ch < nch; ++ch) {
                double v = 0.0;
                const int r = bicubic ? 2 : 1;
                for (int b = y0 - r + 1; b <= y0 + r; ++b)
                    for (int a = x0 - r + 1; a <= x0 + r; ++a) {
                        const double wgt =
                            bicubic ? cubic(x - a) * cubic(y - b)
                                    : std::max(0.0, 1 - std::abs(x - a)) * std::max(0.0, 1 - std::abs(y - b));
                        v += wgt *
                             src[(std::size_t(idx(b, h, periodic_y)) * w + idx(a, w, periodic_x)) * nch + ch];
                    }
                out[p * nch + ch] = v;
            }
        }
    return out;
}

}  // namespace relief::reference

// SPDX-License-Identifier: Apache-2.0
#include "ddm_reference.h"

#include <cmath>

namespace relief::reference {

DdmResult ddm(const std::vector<float>& values, int channels, double scale, double bias, double green_to_row,
              double max_angle_deg, double zero_band)
{
    const std::size_t n = values.size() / channels;
    const double c = std::cos(max_angle_deg * M_PI / 180.0);
    const double s = std::sin(max_angle_deg * M_PI / 180.0);
    DdmResult r;
    r.slopes.assign(2 * n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
        double nx = values[i * channels] * scale + bias;
        double ny = (values[i * channels + 1] * scale + bias) * green_to_row;
        if (std::abs(nx) <= zero_band)
            nx = 0.0;
        if (std::abs(ny) <= zero_band)
            ny = 0.0;
        double nz = channels == 2 ? std::sqrt(std::max(0.0, 1.0 - nx * nx - ny * ny))
                                  : values[i * channels + 2] * scale + bias;
        double len = std::sqrt(nx * nx + ny * ny + nz * nz);
        if (!std::isfinite(len) || len < 1e-6) {
            ++r.invalid;
            continue;
        }
        nx /= len;
        ny /= len;
        nz /= len;
        if (nz < c) {
            double t = std::hypot(nx, ny);
            if (t < 1e-6) {
                ++r.invalid;
                continue;
            }
            nx *= s / t;
            ny *= s / t;
            nz = c;
            ++r.clamped;
        }
        r.slopes[2 * i] = -nx / nz;
        r.slopes[2 * i + 1] = -ny / nz;
    }
    return r;
}

double curl_rms(const std::vector<double>& g, int w, int h)
{
    double sum = 0.0;
    for (int y = 0; y + 1 < h; ++y)
        for (int x = 0; x + 1 < w; ++x) {
            auto at = [&](int xx, int yy, int c) { return g[2 * (std::size_t(yy) * w + xx) + c]; };
            // Circulation around the cell: right edge up minus left edge, etc.
            double a = 0.5 * (at(x + 1, y, 1) + at(x + 1, y + 1, 1) - at(x, y, 1) - at(x, y + 1, 1));
            double b = 0.5 * (at(x, y + 1, 0) + at(x + 1, y + 1, 0) - at(x, y, 0) - at(x + 1, y, 0));
            sum += (a - b) * (a - b);
        }
    return w > 1 && h > 1 ? std::sqrt(sum / (double(w - 1) * (h - 1))) : 0.0;
}

}  // namespace relief::reference

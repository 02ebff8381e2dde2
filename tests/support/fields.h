// SPDX-License-Identifier: Apache-2.0
#pragma once
// Analytic height fields with exact gradients, and normal maps made from
// them in every encoding the DDM stage reads.
#include <OpenImageIO/imagebuf.h>

#include <cmath>
#include <random>
#include <vector>

namespace relief::test {

// n values drawn uniformly from [lo, hi) (a fixed seed: the same every run).
inline std::vector<float> random_field(std::size_t n, unsigned seed, float lo, float hi)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(lo, hi);
    std::vector<float> v(n);
    for (float& x : v)
        x = u(rng);
    return v;
}

struct Wave {
    int kx, ky;        // whole periods across the width / height (tiles)
    double amplitude;  // texels
    double phase;
};

// h(x, y) = sum a cos(2*pi*(kx x / W + ky y / H) + phase), x, y texel centres.
struct PeriodicField {
    int width, height;
    std::vector<Wave> waves;

    double h(double x, double y) const
    {
        double v = 0;
        for (const Wave& w : waves)
            v += w.amplitude * std::cos(arg(w, x, y));
        return v;
    }
    double gx(double x, double y) const
    {
        double v = 0;
        for (const Wave& w : waves)
            v -= w.amplitude * std::sin(arg(w, x, y)) * 2 * M_PI * w.kx / width;
        return v;
    }
    double gy(double x, double y) const
    {
        double v = 0;
        for (const Wave& w : waves)
            v -= w.amplitude * std::sin(arg(w, x, y)) * 2 * M_PI * w.ky / height;
        return v;
    }
    // h(p) - mean of h over the disk of radius R around p (exact: a wave's
    // disk mean is the wave times 2 J1(kR) / (kR)).
    double h_minus_disk_mean(double x, double y, double R) const
    {
        double v = 0;
        for (const Wave& w : waves) {
            double k = 2 * M_PI * std::hypot(double(w.kx) / width, double(w.ky) / height);
            double kr = k * R;
            double factor = kr > 0 ? 2.0 * std::cyl_bessel_j(1.0, kr) / kr : 1.0;
            v += w.amplitude * std::cos(arg(w, x, y)) * (1.0 - factor);
        }
        return v;
    }
    std::vector<double> slopes() const
    {
        std::vector<double> g(2 * std::size_t(width) * height);
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                g[2 * (std::size_t(y) * width + x)] = gx(x, y);
                g[2 * (std::size_t(y) * width + x) + 1] = gy(x, y);
            }
        return g;
    }

private:
    double arg(const Wave& w, double x, double y) const
    {
        return 2 * M_PI * (w.kx * x / width + w.ky * y / height) + w.phase;
    }
};

enum class Green { OpenGL, DirectX };

// Unit normal (image frame) of slope (gx, gy): n = (-gx, -gy, 1) / |.|, with
// the green component stored per convention: OpenGL G' = -n_row, DirectX
// G' = +n_row. Returns the decoded (signed) components R', G', B'.
inline void encode_normal(double gx, double gy, Green green, double out[3])
{
    double len = std::sqrt(gx * gx + gy * gy + 1.0);
    out[0] = -gx / len;
    out[1] = (green == Green::OpenGL ? gy : -gy) / len;
    out[2] = 1.0 / len;
}

// A normal map image of the slopes `g` in the given pixel type. Integer
// types store (v + 1) / 2 (UNORM); float types store v, or (v + 1) / 2 when
// unsigned_float. channels 2 drops z.
inline OIIO::ImageBuf normal_image(const std::vector<double>& g, int w, int h, Green green,
                                   OIIO::TypeDesc type, int channels = 3, bool unsigned_float = false)
{
    OIIO::ImageBuf img(OIIO::ImageSpec(w, h, channels, type));
    const bool unorm = type.basetype == OIIO::TypeDesc::UINT8 || type.basetype == OIIO::TypeDesc::UINT16;
    std::vector<float> px(std::size_t(w) * h * channels);
    for (std::size_t i = 0; i < std::size_t(w) * h; ++i) {
        double n[4] = {0.0, 0.0, 0.0, 1.0};  // a fourth channel is an opaque alpha
        encode_normal(g[2 * i], g[2 * i + 1], green, n);
        for (int c = 0; c < channels; ++c)
            px[i * channels + c] = float(unorm || unsigned_float ? (n[c] + 1.0) * 0.5 : n[c]);
    }
    img.set_pixels(img.roi(), OIIO::TypeDesc::FLOAT, px.data());
    return img;
}

// A smooth tiling height field (stored units, float), w x h: two waves
// with random phases (distortion-correction tests).
inline std::vector<float> waves(int w, int h, double amp = 1.0, unsigned seed = 1)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ph(0.0, 2 * M_PI);
    const double p1 = ph(rng), p2 = ph(rng), p3 = ph(rng);
    std::vector<float> v(std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            v[std::size_t(y) * w + x] =
                float(amp * (0.5 * std::sin(2 * M_PI * x / w + p1) * std::cos(2 * M_PI * 2 * y / h + p2) +
                             0.25 * std::sin(2 * M_PI * (3.0 * x / w + 1.0 * y / h) + p3)));
    return v;
}

// A brick wall as texture artists make them (the held-back map that
// bench_boundary's synthetic brick case stands for): flat brick faces, each
// tilted a little at random, between mortar joints `mortar` texels wide and
// `depth` lower, with sharp one-texel steps; rows `brick_h` high, every
// other row shifted by half a brick. It tiles along x (w a multiple of
// brick_w) and not along y: the rows y0 .. y0 + h - 1 of a wall twice as
// tall, whose rows repeat nowhere (each brick's tilt is its own).
// Heights, and slopes by central differences over the taller wall (x
// wrapping), as a baker makes a normal map from a height.
struct BrickWall {
    std::vector<float> h;
    std::vector<double> g;  // gx, gy per texel
};

inline BrickWall brick_wall(int w, int h, int brick_w, int brick_h, int y0, unsigned seed, int mortar = 2,
                            double depth = 4.0, double tilt = 0.08)
{
    const int tall = 2 * h + y0 + 2;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> t(-tilt, tilt);
    const int per_row = w / brick_w;
    std::vector<double> tx(std::size_t(per_row) * (tall / brick_h + 1)), ty(tx.size()), base(tx.size());
    for (std::size_t i = 0; i < tx.size(); ++i)
        tx[i] = t(rng), ty[i] = t(rng), base[i] = 4 * t(rng);
    std::vector<double> z(std::size_t(w) * tall);
    for (int y = 0; y < tall; ++y) {
        const int row = y / brick_h, yin = y % brick_h;
        const int shift = row % 2 ? brick_w / 2 : 0;
        for (int x = 0; x < w; ++x) {
            const int xs = (x + shift) % w, col = xs / brick_w, xin = xs % brick_w;
            const bool joint = yin < mortar || xin < mortar;
            const std::size_t b = std::size_t(row) * per_row + col;
            z[std::size_t(y) * w + x] =
                joint ? -depth : base[b] + tx[b] * (xin - brick_w / 2.0) + ty[b] * (yin - brick_h / 2.0);
        }
    }
    BrickWall out;
    out.h.resize(std::size_t(w) * h);
    out.g.resize(2 * out.h.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int yy = y + y0 + 1;
            auto at = [&](int xx, int yr) { return z[std::size_t(yr) * w + std::size_t((xx + w) % w)]; };
            const std::size_t i = std::size_t(y) * w + x;
            out.h[i] = float(at(x, yy));
            out.g[2 * i] = (at(x + 1, yy) - at(x - 1, yy)) / 2;
            out.g[2 * i + 1] = (at(x, yy + 1) - at(x, yy - 1)) / 2;
        }
    return out;
}

// g plus Gaussian noise of standard deviation sigma (seeded): slopes that no
// height field has, so a comparison exercises every texel's own value.
inline std::vector<double> plus_noise(std::vector<double> g, double sigma, unsigned seed)
{
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    for (double& v : g)
        v += noise(rng);
    return g;
}

// Smooth tiling slopes plus noise of standard deviation `sigma` that no
// height field has (non-integrable): the golden comparisons' input.
inline std::vector<double> rough_slopes(int w, int h, unsigned seed, double sigma = 0.3)
{
    PeriodicField f{w, h, {{1, 1, 2.0, 0.4}, {2, -1, 1.0, 1.3}}};
    return plus_noise(f.slopes(), sigma, seed);
}

// The root mean square about the mean (the standard deviation), in double.
template <class A>
double rms(const A& a)
{
    double s = 0, m = 0;
    for (const auto v : a)
        m += double(v);
    m /= double(a.size());
    for (const auto v : a)
        s += (double(v) - m) * (double(v) - m);
    return std::sqrt(s / double(a.size()));
}

}  // namespace relief::test

// SPDX-License-Identifier: Apache-2.0
// impl=fast against impl=reference in the same run: agreement and speed.
//
//   bench_rays_agreement [size=1024] [rays=32] [radius=256] [boundary=periodic|clip] [reference=on|off]
//
// Builds a float normal map of a smooth periodic field with fine detail in
// memory, integrates it with both implementations through the public API
// (rational directions; the kernel cache is warmed first), and prints both
// times, their ratio, and max |fast - reference| as a fraction of the
// reference's standard deviation and spread. With boundary=clip it also
// times the fast periodic integration of the same map (median of 5 each,
// alternating) and prints clip / periodic; reference=off skips the slow
// reference kernel.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "image_files.h"
#include "relief/relief.h"

int main(int argc, char** argv)
{
    const int n = argc > 1 ? std::atoi(argv[1]) : 1024;
    const int rays = argc > 2 ? std::atoi(argv[2]) : 32;
    const float radius = argc > 3 ? float(std::atof(argv[3])) : 256.0f;
    const std::string boundary = argc > 4 ? argv[4] : "periodic";
    const std::string reference = argc > 5 ? argv[5] : "on";
    if (n < 8 || rays < 1 || !(radius > 0) || (boundary != "periodic" && boundary != "clip") ||
        (reference != "on" && reference != "off")) {
        std::fprintf(stderr, "usage: %s [size] [rays] [radius] [periodic|clip] [on|off]\n", argv[0]);
        return 2;
    }
    struct Wave {
        int kx, ky;
        double a, phase;
    };
    const Wave waves[] = {{1, 0, 8, .2}, {2, 3, 3, 1}, {-5, 2, 1.5, 2.5}, {9, 7, .6, .4}, {40, -31, .05, 1}};
    OIIO::ImageBuf img(OIIO::ImageSpec(n, n, 3, OIIO::TypeDesc::FLOAT));
    std::vector<float> px(std::size_t(n) * n * 3);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double gx = 0, gy = 0;
            for (const Wave& w : waves) {
                const double arg = 2 * M_PI * (w.kx * double(x) + w.ky * double(y)) / n + w.phase;
                gx -= w.a * std::sin(arg) * 2 * M_PI * w.kx / n;
                gy -= w.a * std::sin(arg) * 2 * M_PI * w.ky / n;
            }
            const double len = std::sqrt(gx * gx + gy * gy + 1);
            float* p = &px[3 * (std::size_t(y) * n + x)];
            p[0] = float(-gx / len);
            p[1] = float(gy / len);  // OpenGL
            p[2] = float(1 / len);
        }
    img.set_pixels(img.roi(), OIIO::TypeDesc::FLOAT, px.data());

    relief::HeightOptions o;
    o.normals.convention = relief::NormalConvention::OpenGL;
    o.method = relief::HeightMethod::Rays;
    o.rays = rays;
    o.radius = radius;
    o.boundary = boundary == "clip" ? relief::Boundary::Free : relief::Boundary::Periodic;
    auto timed = [&](relief::RayImpl impl, std::vector<float>& out) {
        o.impl = impl;
        const auto t0 = std::chrono::steady_clock::now();
        OIIO::ImageBuf h = relief::height(img, o);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (h.has_error()) {
            std::fprintf(stderr, "bench: %s\n", relief::geterror().c_str());
            std::exit(1);
        }
        out.resize(std::size_t(n) * n);
        h.get_pixels(h.roi(), OIIO::TypeDesc::FLOAT, out.data());
        return s;
    };
    std::vector<float> fast, ref;
    timed(relief::RayImpl::Fast, fast);  // warm the kernel cache and the device
    const double tf = timed(relief::RayImpl::Fast, fast);
    if (boundary == "clip") {
        std::vector<double> clip, periodic;
        std::vector<float> scratch;
        for (int k = 0; k < 5; ++k) {
            clip.push_back(timed(relief::RayImpl::Fast, scratch));
            o.boundary = relief::Boundary::Periodic;
            periodic.push_back(timed(relief::RayImpl::Fast, scratch));
            o.boundary = relief::Boundary::Free;
        }
        std::sort(clip.begin(), clip.end());
        std::sort(periodic.begin(), periodic.end());
        std::printf("fast, median of 5: clip %.3f s, periodic %.3f s, clip / periodic %.2f\n", clip[2],
                    periodic[2], clip[2] / periodic[2]);
    }
    if (reference == "off")
        return 0;
    const double tr = timed(relief::RayImpl::Reference, ref);
    const auto [lo, hi] = std::minmax_element(ref.begin(), ref.end());
    const double over_std = bench::max_diff_over_std(ref, fast);
    double worst = 0;
    for (std::size_t i = 0; i < ref.size(); ++i)
        worst = std::max(worst, double(std::abs(fast[i] - ref[i])));
    std::printf("| size | rays | radius | boundary | fast s | reference s | ratio | max diff / std | max "
                "diff / spread |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    std::printf("| %d | %d | %g | %s | %.2f | %.2f | %.1f | %.2e | %.2e |\n", n, rays, radius,
                boundary.c_str(), tf, tr, tr / tf, over_std, worst / (*hi - *lo));
    return 0;
}

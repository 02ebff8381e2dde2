// SPDX-License-Identifier: Apache-2.0
// consumer NORMALS EXPECTED: runs relief::height (defaults) on the normal
// map and compares with EXPECTED (the CLI's default --height); exit 0 when
// they agree to 1e-5 of the height's standard deviation.
#include <relief/relief.h>

#include <cmath>
#include <cstdio>
#include <vector>

int main(int argc, char** argv)
{
    if (argc != 3) {
        std::fprintf(stderr, "usage: consumer NORMALS EXPECTED\n");
        return 2;
    }
    OIIO::ImageBuf normals, expected;
    if (!relief::read_image(normals, argv[1]) || !relief::read_image(expected, argv[2])) {
        std::fprintf(stderr, "consumer: %s\n", relief::geterror().c_str());
        return 2;
    }
    OIIO::ImageBuf h = relief::height(normals);
    if (h.has_error()) {
        std::fprintf(stderr, "consumer: %s\n", relief::geterror().c_str());
        return 1;
    }
    const auto& s = h.spec();
    if (s.width != expected.spec().width || s.height != expected.spec().height || s.nchannels != 1) {
        std::fprintf(stderr, "consumer: the result is %dx%dx%d\n", s.width, s.height, s.nchannels);
        return 1;
    }
    std::vector<float> a(s.image_pixels()), b(s.image_pixels());
    h.get_pixels(h.roi(), OIIO::TypeDesc::FLOAT, a.data());
    expected.get_pixels(expected.roi(), OIIO::TypeDesc::FLOAT, b.data());
    double mean = 0, var = 0, worst = 0;
    for (float v : b)
        mean += v;
    mean /= b.size();
    for (std::size_t i = 0; i < b.size(); ++i) {
        var += (b[i] - mean) * (b[i] - mean);
        worst = std::fmax(worst, std::fabs(double(a[i]) - b[i]));
    }
    const double sd = std::sqrt(var / b.size());
    std::printf("consumer: relief::height vs the CLI: max difference %.3g, std %.3g\n", worst, sd);
    return worst <= 1e-5 * sd && sd > 0 ? 0 : 1;
}

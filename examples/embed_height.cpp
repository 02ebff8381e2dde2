// SPDX-License-Identifier: Apache-2.0
// Embedding relief in a pipeline: normal map in, height map out, through the
// ImageBufAlgo-style API. Build against the `relief` library and run:
//   embed_height normal.png height.exr
#include <relief/relief.h>

#include <cstdio>

int main(int argc, char** argv)
{
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s normal.png height.exr\n", argv[0]);
        return 2;
    }
    OIIO::ImageBuf normals;
    if (!relief::read_image(normals, argv[1])) {
        std::fprintf(stderr, "%s\n", relief::geterror().c_str());
        return 1;
    }

    relief::HeightOptions opt;  // documented defaults: auto convention, 32 rays, radius 64
    opt.boundary = relief::Boundary::Auto;
    opt.exec.on_message = [](relief::Severity s, const std::string& m) {
        std::fprintf(stderr, "%s%s\n", s == relief::Severity::Warning ? "warning: " : "", m.c_str());
    };

    OIIO::ImageBuf h = relief::height(normals, opt);
    if (h.has_error()) {
        std::fprintf(stderr, "%s\n", relief::geterror().c_str());
        return 1;
    }
    std::printf("convention %s, %s\n", h.spec().get_string_attribute("relief:normal_convention").c_str(),
                h.spec().get_string_attribute("relief:parameters").c_str());
    if (!relief::write_image(h, argv[2])) {
        std::fprintf(stderr, "%s\n", relief::geterror().c_str());
        return 1;
    }
    return 0;
}

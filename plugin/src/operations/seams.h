// SPDX-License-Identifier: Apache-2.0
#pragma once
// Whether a height map tiles: its jumps across the wrap seams against those
// between neighbours. correct's boundary=auto and the checks of a height
// (normals, preview, tessellation) share it.
#include <OpenImageIO/imagebuf.h>

#include <string>
#include <vector>

#include "relief/height.h"
#include "relief/options.h"

namespace relief::detail {

// Channel 0 of `img` over `roi` as floats; throws naming `what` ("the
// height map") when the pixels cannot be read.
std::vector<float> channel0(const OIIO::ImageBuf& img, OIIO::ROI roi, const char* what);

// A height map's channel 0 over `roi` (saying so, as `operation`'s Info,
// when it has more channels); throws at the first NaN or infinite value,
// and when `scale` x the largest |value| is not a finite float (a surface
// the checks cannot measure).
std::vector<float> height_channel(const OIIO::ImageBuf& height, OIIO::ROI roi, const Execution& exec,
                                  const std::string& operation, float scale = 1.0f);

// The region of a height map an operation works on: `roi` resolved as
// every operation resolves it (resolve_roi), its size, and height_channel()
// over it.
struct HeightRegion {
    OIIO::ROI roi;
    int w = 0, h = 0;
    std::vector<float> values;
};
HeightRegion height_region(const OIIO::ImageBuf& height, OIIO::ROI roi, const Execution& exec,
                           const std::string& operation, float scale = 1.0f);

// Whether a height wraps along x and along y.
struct Wrap {
    bool x = false, y = false;
};

// The seam test of boundary=auto on a height, each axis on its own: the
// height jump across the axis's wrap seam over the mean jump between
// neighbours, periodic at most 2. A map under two texels across is
// periodic on neither axis (ratios 0: a seam needs two texels).
struct SeamTest {
    double ratio_x = 0.0, ratio_y = 0.0;
    Wrap periodic;
    // The numbers for a notice: "height jump across ...: x R, y R; ...".
    std::string numbers() const;
};
SeamTest seam_test(const std::vector<float>& h, int w, int ht);

// The boundary a check applies to `height` (its pixels h, w x ht), per
// axis: `requested` unless Auto; then the boundary relief:parameters
// records (the one the height was integrated with), else seam_test() for
// each axis on Auto. Says which, and why, as `operation`'s Notice.
Wrap height_wrap(const OIIO::ImageBuf& height, const std::vector<float>& h, int w, int ht,
                 Boundaries requested, const Execution& exec, const std::string& operation);

// "periodic", "free", or x's and y's where they differ: "periodic,free".
std::string wrap_name(Wrap wrap);

}  // namespace relief::detail

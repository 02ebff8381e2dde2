// SPDX-License-Identifier: Apache-2.0
#pragma once
// Reading the benchmarks' images and comparing results.
#include <OpenImageIO/imagebuf.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace bench {

// The first `nch` channels of the image at `path` (all of them where nch is
// 0) as floats, row by row; w and h get its size, `boundary` (if given) its
// relief:boundary attribute. Exits naming the file when it cannot be read.
inline std::vector<float> read_channels(const std::string& path, int& w, int& h, int nch = 0,
                                        std::string* boundary = nullptr)
{
    OIIO::ImageBuf b(path);
    if (!b.read(0, 0, true, OIIO::TypeDesc::FLOAT)) {
        std::fprintf(stderr, "bench: cannot read %s\n", path.c_str());
        std::exit(1);
    }
    w = b.spec().width;
    h = b.spec().height;
    if (boundary)
        *boundary = b.spec().get_string_attribute("relief:boundary");
    OIIO::ROI r = b.roi();
    if (nch > 0)
        r.chend = nch;
    std::vector<float> v(std::size_t(w) * h * r.nchannels());
    b.get_pixels(r, OIIO::TypeDesc::FLOAT, v.data());
    return v;
}

inline std::vector<float> read_channels(const std::string& path)
{
    int w = 0, h = 0;
    return read_channels(path, w, h);
}

// The folders of a data set (the maintainers' maps, scripts/corpus's):
// those under `root` that hold normal.png and height.png, sorted.
inline std::vector<std::filesystem::path> map_folders(const std::filesystem::path& root)
{
    std::vector<std::filesystem::path> out;
    for (const auto& e : std::filesystem::directory_iterator(root))
        if (std::filesystem::exists(e.path() / "normal.png") &&
            std::filesystem::exists(e.path() / "height.png"))
            out.push_back(e.path());
    std::sort(out.begin(), out.end());
    return out;
}

// Channel c of an image in memory, row by row.
inline std::vector<float> channel(const OIIO::ImageBuf& b, int c)
{
    OIIO::ROI r = b.roi();
    r.chbegin = c;
    r.chend = c + 1;
    std::vector<float> v(std::size_t(r.width()) * r.height());
    b.get_pixels(r, OIIO::TypeDesc::FLOAT, v.data());
    return v;
}

// Writes n x n RGB pixels of `type` (row by row) to `path`, or exits naming it.
template <class T>
void write_rgb(const std::string& path, int n, OIIO::TypeDesc type, const std::vector<T>& px)
{
    OIIO::ImageBuf img(OIIO::ImageSpec(n, n, 3, type));
    img.set_pixels(img.roi(), type, px.data());
    if (!img.write(path)) {
        std::fprintf(stderr, "bench: cannot write %s\n", path.c_str());
        std::exit(1);
    }
}

// The largest |a - b| as a fraction of a's standard deviation (the
// difference itself where a is constant; infinite where the sizes differ).
inline double max_diff_over_std(const std::vector<float>& a, const std::vector<float>& b)
{
    if (a.size() != b.size() || a.empty())
        return INFINITY;
    double mean = 0, var = 0, worst = 0;
    for (float v : a)
        mean += v;
    mean /= double(a.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
        var += (a[i] - mean) * (a[i] - mean);
        worst = std::max(worst, double(std::abs(a[i] - b[i])));
    }
    const double sd = std::sqrt(var / double(a.size()));
    return sd > 0 ? worst / sd : worst;
}

}  // namespace bench

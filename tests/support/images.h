// SPDX-License-Identifier: Apache-2.0
#pragma once
// Small helpers the glue tests share: images from pixel vectors and back,
// scratch folders, and the skip marker ctest turns into "Skipped".
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace relief::test {

// The bundled sample (examples/data/gk_metal_tech_01): a DirectX normal map
// and the height it was authored from.
inline const std::string kSampleNormal = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
inline const std::string kSampleHeight = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/height.png";

// An in-memory image of `format` holding `px` (w*h*nch floats, as OIIO
// converts them: UNORM types take [0, 1]).
inline OIIO::ImageBuf image(int w, int h, int nch, const std::vector<float>& px,
                            OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT)
{
    OIIO::ImageBuf b(OIIO::ImageSpec(w, h, nch, format));
    b.set_pixels(b.roi(), OIIO::TypeDesc::FLOAT, px.data());
    return b;
}

// All channels of `b` as floats.
inline std::vector<float> pixels(const OIIO::ImageBuf& b)
{
    std::vector<float> v(std::size_t(b.spec().width) * b.spec().height * b.nchannels());
    b.get_pixels(b.roi(), OIIO::TypeDesc::FLOAT, v.data());
    return v;
}

// Reads a file's pixels as floats (no relief conversions). Not through
// ImageBuf: OIIO's shared ImageCache would hand back an earlier file of
// the same name.
inline std::vector<float> file_pixels(const std::filesystem::path& p)
{
    auto in = OIIO::ImageInput::open(p.string());
    if (!in)
        return {};
    const OIIO::ImageSpec& spec = in->spec();
    std::vector<float> v(std::size_t(spec.width) * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, v.data()))
        return {};
    return v;
}

// An empty folder under the test build's tmp/ (removed first).
inline std::filesystem::path scratch(const std::string& name)
{
    namespace fs = std::filesystem;
    fs::path d = fs::path(RELIEF_TEST_TMP) / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

// The largest |a[i] - b[i]|; infinite when the sizes differ or a
// difference is not a number (a NaN on either side).
template <class A, class B>
double max_abs_diff(const A& a, const B& b)
{
    double m = a.size() == b.size() ? 0.0 : INFINITY;
    for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
        const double d = std::abs(double(a[i]) - double(b[i]));
        m = std::isnan(d) ? INFINITY : std::max(m, d);
    }
    return m;
}

template <class A>
double max_abs(const A& a)
{
    double m = 0.0;
    for (auto v : a)
        m = std::max(m, std::abs(double(v)));
    return m;
}

// A number as std::ostream writes it by default ("0.3", "7.5", "5").
inline std::string format_number(double v)
{
    std::ostringstream s;
    s << v;
    return s.str();
}

// Prints the marker that tests/CMakeLists.txt's SKIP_REGULAR_EXPRESSION
// turns into a skipped ctest entry (Catch2 2 has no SKIP of its own).
inline void mark_skipped(const std::string& why)
{
    std::cout << "relief-test-skipped: " << why << std::endl;
}

}  // namespace relief::test

// SPDX-License-Identifier: Apache-2.0
// Real textures: the bundled samples always, the shared data set when it is
// there (a fresh clone of the project does not have ../shared).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "relief/relief.h"
#include "support/accuracy.h"
#include "support/images.h"
#include "support/run_cli.h"

namespace fs = std::filesystem;
using OIIO::TypeDesc;
namespace test = relief::test;

namespace {

// The shared data sets' folders (../shared/data/*), or none, with the test
// marked skipped, where that folder is absent (as in CI).
std::vector<fs::path> shared_sets()
{
    const fs::path root(RELIEF_SHARED_DATA);
    if (!fs::is_directory(root)) {
        test::mark_skipped("../shared/data is absent");
        return {};
    }
    std::vector<fs::path> sets;
    for (const auto& entry : fs::directory_iterator(root))
        if (entry.is_directory())
            sets.push_back(entry.path());
    std::sort(sets.begin(), sets.end());
    return sets;
}

std::vector<double> channel0(const OIIO::ImageBuf& img)
{
    std::vector<float> px(img.spec().image_pixels() * img.spec().nchannels);
    img.get_pixels(img.roi(), TypeDesc::FLOAT, px.data());
    std::vector<double> out(img.spec().image_pixels());
    for (std::size_t i = 0; i < out.size(); ++i)
        out[i] = px[i * img.spec().nchannels];
    return out;
}

// h - mean of h over the texels within `radius` (periodic), the ray method's
// target for a known height map.
std::vector<double> minus_disk_mean(const std::vector<double>& h, int w, int ht, int radius)
{
    std::vector<std::pair<int, int>> disk;
    for (int dy = -radius; dy <= radius; ++dy)
        for (int dx = -radius; dx <= radius; ++dx)
            if (dx * dx + dy * dy <= radius * radius)
                disk.push_back({dx, dy});
    std::vector<double> out(h.size());
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x) {
            double s = 0;
            for (auto [dx, dy] : disk)
                s += h[std::size_t((y + dy + ht) % ht) * w + (x + dx + w) % w];
            out[std::size_t(y) * w + x] = h[std::size_t(y) * w + x] - s / double(disk.size());
        }
    return out;
}

OIIO::ImageBuf read(const fs::path& p)
{
    OIIO::ImageBuf img;
    REQUIRE(relief::read_image(img, p.string()));
    return img;
}

std::string convention_of(const OIIO::ImageBuf& normals)
{
    auto s = relief::slopes(normals);
    REQUIRE_FALSE(s.has_error());
    return s.spec().get_string_attribute("relief:normal_convention");
}

}  // namespace

TEST_CASE("real samples: auto finds the green convention", "[real]")
{
    const fs::path data(RELIEF_TEST_DATA);
    CHECK(convention_of(read(data / "gk_metal_tech_01" / "normal.png")) == "directx");
    CHECK(convention_of(read(data / "dem_jacksboro" / "normal.png")) == "opengl");
}

TEST_CASE("real sample: ray heights match the author's height map, right way up", "[real]")
{
    const fs::path dir = fs::path(RELIEF_TEST_DATA) / "gk_metal_tech_01";
    auto normals = read(dir / "normal.png");
    relief::HeightOptions o;
    o.method = relief::HeightMethod::Rays;
    o.rays = 32;
    o.radius = 16;
    auto est = relief::height(normals, o);
    REQUIRE_FALSE(est.has_error());
    auto truth_img = read(dir / "height.png");
    const int w = truth_img.spec().width, h = truth_img.spec().height;
    auto truth = minus_disk_mean(channel0(truth_img), w, h, 16);
    const test::AffineFit fit = test::affine_fit(channel0(est), truth);
    const double a = fit.a, e = fit.rmse / fit.truth_range;
    INFO("NRMSE after affine fit: " << e << ", scale " << a);
    CHECK(a > 0);     // not upside down
    CHECK(e < 0.02);  // measured 0.0063
}

TEST_CASE("real sample: Poisson heights match the author's height map", "[real][poisson]")
{
    const fs::path dir = fs::path(RELIEF_TEST_DATA) / "gk_metal_tech_01";
    auto est = relief::height(read(dir / "normal.png"));  // method=auto: poisson
    REQUIRE_FALSE(est.has_error());
    CHECK(est.spec().get_string_attribute("relief:method") == "poisson");
    auto truth = channel0(read(dir / "height.png"));
    const test::AffineFit fit = test::affine_fit(channel0(est), truth);
    const double a = fit.a, e = fit.rmse / fit.truth_range;
    INFO("NRMSE after affine fit: " << e << ", scale " << a);
    CHECK(a > 0);
    CHECK(e < 0.02);
}

TEST_CASE("shared data set: auto finds every map's convention", "[real][shared][slow]")
{
    int checked = 0;
    for (const fs::path& set : shared_sets()) {
        if (!fs::exists(set / "meta.json"))
            continue;
        const std::string meta = test::slurp(set / "meta.json");
        const std::string want = meta.find("\"green\": \"Y+") != std::string::npos ? "opengl" : "directx";
        INFO(set.filename().string());
        CHECK(convention_of(read(set / "normal.png")) == want);
        ++checked;
    }
    CHECK(checked >= 13);
}

TEST_CASE("shared data set: boundary=auto agrees with the maps' tiling", "[real][shared][slow]")
{
    // provenance.txt says "tiling: yes", "no" or "approximately" (judged by
    // eye and by height-map metrics); the approximate ones may go either way.
    int checked = 0;
    for (const fs::path& set : shared_sets()) {
        const std::string text = test::slurp(set / "provenance.txt");
        const std::size_t at = text.find("tiling: ");
        if (at == std::string::npos)
            continue;
        const std::string label = text.substr(at + 8, text.find_first_of(" \n", at + 8) - at - 8);
        if (label != "yes" && label != "no")
            continue;
        std::string said;
        relief::HeightOptions o;
        o.exec.on_message = [&](relief::Severity, const std::string& m) {
            if (m.rfind("boundary: ", 0) == 0)
                said = m;
        };
        auto h = relief::height(read(set / "normal.png"), o);
        INFO(set.filename().string() << ": " << label << "; " << said);
        REQUIRE_FALSE(h.has_error());
        // Both axes: "periodic (" and not "periodic,free (".
        CHECK(said.rfind(label == "yes" ? "boundary: periodic (" : "boundary: free (", 0) == 0);
        ++checked;
    }
    CHECK(checked >= 10);
}

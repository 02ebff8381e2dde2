// SPDX-License-Identifier: Apache-2.0
// UDIM sets integrated as one surface (relief::height_udim): by definition
// the solve of the tiles laid out on one canvas, missing tiles weighted 0,
// so each mode is checked against height() of an assembled map.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebufalgo.h>

#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "relief/relief.h"
#include "relief/relief_c.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/option_cases.h"

using namespace relief;
using relief::test::pixels;

namespace {

constexpr int kW = 32, kH = 24;  // one tile

// A smooth field that tiles over 2x2 tiles, with a little noise so that
// every texel's slope counts.
OIIO::ImageBuf whole_map(unsigned seed = 1, double noise = 0.02)
{
    test::PeriodicField f{2 * kW, 2 * kH, {{1, 1, 3.0, 0.3}, {2, -1, 1.5, 1.1}, {3, 2, 0.7, 2.0}}};
    return test::normal_image(test::plus_noise(f.slopes(), noise, seed), 2 * kW, 2 * kH, test::Green::OpenGL,
                              OIIO::TypeDesc::FLOAT);
}

// Tile `number` of a 2x2 canvas (1001, 1002 bottom, 1011, 1012 top: v runs up).
OIIO::ROI tile_roi(int number)
{
    const int u = (number - 1001) % 10, v = (number - 1001) / 10;
    const int x = u * kW, y = (1 - v) * kH;
    return OIIO::ROI(x, x + kW, y, y + kH);
}

OIIO::ImageBuf cut(const OIIO::ImageBuf& whole, int number)
{
    OIIO::ImageBuf t = OIIO::ImageBufAlgo::cut(whole, tile_roi(number));
    REQUIRE(!t.has_error());
    return t;
}

struct Set {
    std::map<int, OIIO::ImageBuf> images;
    std::vector<UdimTile> tiles() const
    {
        std::vector<UdimTile> v;
        for (const auto& [n, img] : images)
            v.push_back({n, &img});
        return v;
    }
};

Set set_of(const OIIO::ImageBuf& whole, std::vector<int> numbers = {1001, 1002, 1011, 1012})
{
    Set s;
    for (int n : numbers)
        s.images[n] = cut(whole, n);
    return s;
}

// dst[i] (the tiles in ascending order) against `expected` cut at each tile.
void check_cut_of(const std::vector<OIIO::ImageBuf>& dst, const Set& s, const OIIO::ImageBuf& expected)
{
    REQUIRE(dst.size() == s.images.size());
    std::size_t i = 0;
    for (const auto& [n, img] : s.images) {
        INFO("tile " << n);
        CHECK(pixels(dst[i]) == pixels(cut(expected, n)));
        CHECK(dst[i].spec().width == kW);
        ++i;
    }
}

HeightOptions with_boundary(Boundaries b, UdimMode mode = UdimMode::Joint)
{
    HeightOptions o;
    o.boundary = b;
    o.udim = mode;
    return o;
}

}  // namespace

TEST_CASE("udim joint: a full set equals the solve of the assembled map, cut into tiles", "[udim]")
{
    const OIIO::ImageBuf whole = whole_map();
    const Set s = set_of(whole);
    for (Boundaries b : {Boundaries(Boundary::Periodic), Boundaries(Boundary::Free),
                         Boundaries(Boundary::Periodic, Boundary::Free)}) {
        INFO("boundary " << int(b.x) << "," << int(b.y));
        std::vector<OIIO::ImageBuf> dst;
        REQUIRE(height_udim(dst, s.tiles(), with_boundary(b)));
        check_cut_of(dst, s, height(whole, with_boundary(b)));
        CHECK(dst[0].spec().get_string_attribute("relief:udim") == "joint 1001,1002,1011,1012");
    }
    // auto (the default): every edge continues, so all are joined, and the
    // canvas takes the boundary auto would give the whole map
    UdimReport report;
    const std::vector<OIIO::ImageBuf> dst = height_udim(s.tiles(), {}, &report);
    check_cut_of(dst, s, height(whole));
    REQUIRE(report.edges.size() == 4);
    for (const UdimEdge& e : report.edges) {
        INFO(e.a << "-" << e.b << ": " << e.seam << " vs " << e.adjacent);
        CHECK(e.joined);
    }
    CHECK(report.groups == std::vector<std::vector<int>>{{1001, 1002, 1011, 1012}});
}

TEST_CASE("udim joint: a missing tile is weighted 0, as a mask over the assembled map would", "[udim]")
{
    const OIIO::ImageBuf whole = whole_map();
    const Set s = set_of(whole, {1001, 1002, 1011});
    OIIO::ImageBuf mask(OIIO::ImageSpec(2 * kW, 2 * kH, 1, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(mask, {1.0f});
    OIIO::ImageBufAlgo::zero(mask, tile_roi(1012));
    for (Boundaries b : {Boundaries(Boundary::Free), Boundaries(Boundary::Periodic)}) {
        INFO("boundary " << int(b.x));
        HeightOptions masked = with_boundary(b, UdimMode::Each);
        masked.mask = &mask;
        std::vector<OIIO::ImageBuf> dst;
        REQUIRE(height_udim(dst, s.tiles(), with_boundary(b)));
        check_cut_of(dst, s, height(whole, masked));
    }
    // what a mask cannot do yet, a missing tile cannot either; rays join
    // only a full rectangle
    HeightOptions o = with_boundary(Boundary::Free);
    o.highpass = 16.0f;
    std::vector<OIIO::ImageBuf> dst;
    CHECK_FALSE(height_udim(dst, s.tiles(), o));
    const std::string why = geterror();
    CHECK(why.find("(1012) are masked out, and highpass") != std::string::npos);
    o.highpass = 0.0f;
    o.method = HeightMethod::Rays;
    o.boundary = Boundary::Periodic;
    CHECK_FALSE(height_udim(dst, s.tiles(), o));
    CHECK(geterror().find("method=rays joins only a full rectangle") != std::string::npos);
    CHECK(dst.empty());
    // a full set joins under rays too: the rays of the assembled map
    const Set full = set_of(whole);
    REQUIRE(height_udim(dst, full.tiles(), o));
    HeightOptions rays = o;
    rays.udim = UdimMode::Each;
    check_cut_of(dst, full, height(whole, rays));
}

TEST_CASE("udim auto: a tile unrelated to its neighbours is solved alone, the others stay joined", "[udim]")
{
    const OIIO::ImageBuf whole = whole_map();
    Set s = set_of(whole);
    // another surface altogether, rough (on edges of 32 texels two unrelated
    // smooth surfaces can correlate by chance: 0.51 against 0.86 for one)
    test::PeriodicField other{kW, kH, {{5, 2, 0.5, 0.9}, {2, 5, 0.5, 0.2}}};
    s.images[1012] = test::normal_image(test::plus_noise(other.slopes(), 0.5, 7), kW, kH, test::Green::OpenGL,
                                        OIIO::TypeDesc::FLOAT);
    UdimReport report;
    std::vector<OIIO::ImageBuf> dst;
    REQUIRE(height_udim(dst, s.tiles(), with_boundary(Boundary::Auto, UdimMode::Auto), &report));
    for (const UdimEdge& e : report.edges) {
        INFO(e.a << "-" << e.b << ": " << e.seam << " vs " << e.adjacent);
        CHECK(e.joined == (e.b != 1012));
    }
    CHECK(report.groups == std::vector<std::vector<int>>{{1001, 1002, 1011}, {1012}});
    // 1012: the same bits as its own height()
    CHECK(pixels(dst[3]) == pixels(height(s.images[1012])));
    CHECK(dst[3].spec().get_string_attribute("relief:udim") == "alone");
    // the others: the joint solve of the three
    Set three = s;
    three.images.erase(1012);
    const std::vector<OIIO::ImageBuf> joined = height_udim(three.tiles(), with_boundary(Boundary::Auto));
    REQUIRE(joined.size() == 3);
    for (int i = 0; i < 3; ++i)
        CHECK(pixels(dst[i]) == pixels(joined[i]));
}

TEST_CASE("udim each: every tile alone, and sets that cannot be solved are refused with a message", "[udim]")
{
    const OIIO::ImageBuf whole = whole_map();
    Set s = set_of(whole);
    std::vector<OIIO::ImageBuf> dst;
    REQUIRE(height_udim(dst, s.tiles(), with_boundary(Boundary::Auto, UdimMode::Each)));
    std::size_t i = 0;
    for (const auto& [n, img] : s.images) {
        CHECK(pixels(dst[i]) == pixels(height(img)));
        CHECK(!dst[i].spec().find_attribute("relief:udim"));
        ++i;
    }
    // a mask image is one tile's: joint refuses it, auto solves each tile alone
    OIIO::ImageBuf mask(OIIO::ImageSpec(kW, kH, 1, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(mask, {1.0f});
    HeightOptions o;
    o.mask = &mask;
    o.udim = UdimMode::Joint;
    CHECK_FALSE(height_udim(dst, s.tiles(), o));
    CHECK(geterror().find("udim=joint takes mask=alpha") != std::string::npos);
    o.udim = UdimMode::Auto;
    UdimReport report;
    REQUIRE(height_udim(dst, s.tiles(), o, &report));
    CHECK(report.groups.size() == 4);
    CHECK(pixels(dst[0]) == pixels(height(s.images[1001], o)));

    auto refused = [&](std::vector<UdimTile> tiles, const std::string& why, UdimMode mode = UdimMode::Joint) {
        INFO(why);
        std::vector<OIIO::ImageBuf> out(1);
        CHECK_FALSE(height_udim(out, tiles, with_boundary(Boundary::Auto, mode)));
        CHECK(geterror().find(why) != std::string::npos);
        CHECK(out.empty());
    };
    const OIIO::ImageBuf* a = &s.images[1001];
    refused({}, "at least one tile");
    refused({{1001, a}, {1001, a}}, "tile 1001 is given twice");
    refused({{1000, a}}, "from 1001 to 1999, got 1000");
    refused({{2000, a}}, "from 1001 to 1999, got 2000");
    refused({{1001, nullptr}}, "tile 1001 has no image");
    // tiles of different sizes cannot share a canvas; auto cuts their edge
    const OIIO::ImageBuf small = OIIO::ImageBufAlgo::cut(*a, OIIO::ROI(0, kW / 2, 0, kH));
    refused({{1001, a}, {1002, &small}}, "UDIM tiles solved together must match: tile 1002 is 16x24");
    REQUIRE(height_udim(dst, {{1001, a}, {1002, &small}}, with_boundary(Boundary::Auto, UdimMode::Auto),
                        &report));
    CHECK(report.edges.size() == 1);
    CHECK_FALSE(report.edges[0].joined);
    CHECK(pixels(dst[1]) == pixels(height(small)));
}

TEST_CASE("udim through the C ABI: relief_run_tiles equals height_udim, refusals zero the outputs",
          "[udim][abi]")
{
    const OIIO::ImageBuf whole = whole_map();
    const Set s = set_of(whole);
    std::vector<std::vector<float>> px;
    std::vector<relief_image> in;
    std::vector<int> numbers;
    for (const auto& [n, img] : s.images) {
        px.push_back(pixels(img));
        numbers.push_back(n);
    }
    for (std::vector<float>& p : px)
        in.push_back({kW, kH, 3, RELIEF_FLOAT, p.data(), nullptr});
    const std::vector<OIIO::ImageBuf> want = height_udim(s.tiles(), with_boundary(Boundary::Free));
    std::vector<relief_image> out(in.size());
    REQUIRE(relief_run_tiles("auto", "height", "udim=joint:boundary=free", numbers.data(), in.data(),
                             int(in.size()), out.data()) == RELIEF_OK);
    for (std::size_t i = 0; i < out.size(); ++i) {
        INFO("tile " << numbers[i]);
        REQUIRE((out[i].width == kW && out[i].height == kH && out[i].channels == 1));
        const float* h = static_cast<const float*>(out[i].pixels);
        CHECK(std::vector<float>(h, h + kW * kH) == pixels(want[i]));
        CHECK(std::string(out[i].metadata).find("relief:udim=joint 1001,1002,1011,1012\n") !=
              std::string::npos);
        relief_image_free(&out[i]);
    }

    // Refused before any work: RELIEF_INVALID, every output zeroed.
    const auto refused = [&](const char* op, const char* mods, int n, const char* says) {
        std::vector<relief_image> o(in.size(), relief_image{1, 1, 1, RELIEF_FLOAT, nullptr, nullptr});
        CHECK(relief_run_tiles("auto", op, mods, numbers.data(), in.data(), n, o.data()) == RELIEF_INVALID);
        CHECK(std::string(relief_last_error()).find(says) != std::string::npos);
        // Only the n outputs the caller named are relief's to touch.
        for (int i = 0; i < int(o.size()); ++i)
            CHECK((i < n ? (o[i].width == 0 && o[i].pixels == nullptr) : o[i].width == 1));
    };
    refused("bake", "", 4, "does not take the tiles");
    refused("height", "udim=sometimes", 4, "udim");
    refused("height", "", 0, "at least one tile");
    refused("height", "", -1, "at least one tile");
    CHECK(relief_run_tiles("auto", "height", "", numbers.data(), in.data(), 4, nullptr) == RELIEF_INVALID);
    // Tile numbers out of range or given twice: refused as the counts are.
    for (const auto& [bad, says] :
         {std::pair{std::vector<int>{1001, 1002, 1002, 1012}, "tile 1002 is given twice"},
          std::pair{std::vector<int>{1000, 1002, 1011, 1012}, "1001 to 1999, got 1000"},
          std::pair{std::vector<int>{1001, 1002, 1011, 2000}, "1001 to 1999, got 2000"}}) {
        // (outputs holding whatever the caller's memory held: refused before
        // they are relief's, they are zeroed, never freed)
        std::vector<relief_image> o(in.size());
        std::memset(static_cast<void*>(o.data()), 0x5a, sizeof(relief_image) * o.size());
        CHECK(relief_run_tiles("auto", "height", "", bad.data(), in.data(), 4, o.data()) == RELIEF_INVALID);
        CHECK(std::string(relief_last_error()).find(says) != std::string::npos);
        for (const relief_image& r : o)
            CHECK((r.width == 0 && r.pixels == nullptr));
    }
    // No numbers, or no images, for the tiles: refused, saying so.
    for (const bool numbers_missing : {true, false}) {
        std::vector<relief_image> o(in.size());
        CHECK(relief_run_tiles("auto", "height", "", numbers_missing ? nullptr : numbers.data(),
                               numbers_missing ? in.data() : nullptr, 4, o.data()) == RELIEF_INVALID);
        CHECK(std::string(relief_last_error()).find("at least one tile") != std::string::npos);
    }
    // The last tile number there is, 1999, is a tile like any other; an
    // image without pixels is refused.
    {
        const int last = 1999;
        std::vector<relief_image> one(1);
        CHECK(relief_run_tiles("auto", "height", "boundary=free", &last, in.data(), 1, one.data()) ==
              RELIEF_OK);
        CHECK(one[0].pixels != nullptr);
        relief_image_free(&one[0]);
        relief_image no_pixels = in[0];
        no_pixels.pixels = nullptr;
        CHECK(relief_run_tiles("auto", "height", "", &last, &no_pixels, 1, one.data()) == RELIEF_INVALID);
        CHECK(std::string(relief_last_error()).find("has no pixels (NULL)") != std::string::npos);
        CHECK(relief_run_on("auto", "height", "", &no_pixels, 1, one.data()) == RELIEF_INVALID);
        CHECK(std::string(relief_last_error()).find("has no pixels (NULL)") != std::string::npos);
    }
    // One tile is a set of one: its own height, as height() gives it.
    {
        std::vector<relief_image> one(1);
        REQUIRE(relief_run_tiles("auto", "height", "boundary=free", numbers.data(), in.data(), 1,
                                 one.data()) == RELIEF_OK);
        REQUIRE((one[0].width == kW && one[0].height == kH && one[0].channels == 1));
        const float* h = static_cast<const float*>(one[0].pixels);
        CHECK(std::vector<float>(h, h + kW * kH) ==
              pixels(height(s.images.begin()->second, with_boundary(Boundary::Free))));
        relief_image_free(&one[0]);
    }
    // Failed during the work: RELIEF_FAILED, saying why, nothing left.
    const auto failed = [&](const char* device, const char* says) {
        std::vector<relief_image> o(in.size());
        CHECK(relief_run_tiles(device, "height", "udim=joint", numbers.data(), in.data(), 4, o.data()) ==
              RELIEF_FAILED);
        CHECK(std::string(relief_last_error()).find(says) != std::string::npos);
        for (const relief_image& r : o)
            CHECK(r.pixels == nullptr);
    };
    // The device asked for is the one used: one that is not there fails.
    failed("9:9", "9:9");
    // A tile of another size fails the joint solve.
    in[1].width = kW / 2;
    failed("auto", "must match");
}

namespace {

// The same images numbered elsewhere on the 10-wide grid of tiles.
Set renumbered(const Set& s, int first)
{
    Set r;
    for (const auto& [n, img] : s.images)
        r.images[first + (n - 1001)] = img;
    return r;
}

}  // namespace

TEST_CASE(
    "udim: a set laid out anywhere on the grid gives the same heights, with edges between neighbours only",
    "[udim]")
{
    const OIIO::ImageBuf whole = whole_map();
    const Set s = set_of(whole);
    for (UdimMode mode : {UdimMode::Joint, UdimMode::Auto}) {
        const std::vector<OIIO::ImageBuf> want = height_udim(s.tiles(), with_boundary(Boundary::Free, mode));
        REQUIRE(want.size() == 4);
        // the right column (u 8, 9) and the top rows (v 98, 99) of the grid
        // (whose last tile is 1999: u 8)
        for (int first : {1009, 1981, 1988}) {
            INFO("mode " << int(mode) << ", first tile " << first);
            const Set r = renumbered(s, first);
            UdimReport report;
            std::vector<OIIO::ImageBuf> dst;
            REQUIRE(height_udim(dst, r.tiles(), with_boundary(Boundary::Free, mode), &report));
            REQUIRE(dst.size() == 4);
            for (int i = 0; i < 4; ++i)
                CHECK(pixels(dst[i]) == pixels(want[i]));
            CHECK(report.groups.size() == 1);
        }
    }
    // one row at the top of the grid (v 99): the two tiles' own canvas, no
    // row of missing tiles below them (which rays, refusing masks, could not
    // solve)
    const Set bottom = set_of(whole, {1001, 1002});
    Set top;
    top.images[1991] = bottom.images.at(1001);
    top.images[1992] = bottom.images.at(1002);
    for (HeightMethod method : {HeightMethod::Poisson, HeightMethod::Rays}) {
        HeightOptions o = with_boundary(Boundary::Free);
        o.method = method;
        const std::vector<OIIO::ImageBuf> want = height_udim(bottom.tiles(), o);
        std::vector<OIIO::ImageBuf> dst;
        INFO("method " << int(method));
        REQUIRE(height_udim(dst, top.tiles(), o));
        REQUIRE(dst.size() == 2);
        CHECK(pixels(dst[0]) == pixels(want[0]));
        CHECK(pixels(dst[1]) == pixels(want[1]));
        CHECK(dst[0].spec().get_string_attribute("relief:udim") == "joint 1991,1992");
    }
    // edges: only between tiles side by side on the grid (u 9 and the next
    // row's u 0 are not), and between rows
    UdimReport report;
    std::vector<OIIO::ImageBuf> dst;
    Set pair;
    pair.images[1010] = s.images.at(1001);
    pair.images[1011] = s.images.at(1002);
    REQUIRE(height_udim(dst, pair.tiles(), with_boundary(Boundary::Auto, UdimMode::Auto), &report));
    CHECK(report.edges.empty());
    CHECK(report.groups.size() == 2);
    pair.images.clear();
    pair.images[1009] = s.images.at(1001);
    pair.images[1010] = s.images.at(1002);
    REQUIRE(height_udim(dst, pair.tiles(), with_boundary(Boundary::Auto, UdimMode::Auto), &report));
    REQUIRE(report.edges.size() == 1);
    CHECK((report.edges[0].a == 1009 && report.edges[0].b == 1010));
}

TEST_CASE("udim joint: the canvas of normals counts in the memory a set is refused for", "[udim][memory]")
{
    // Joined, the set is one map assembled on a canvas: its normals (float
    // RGB, 12 bytes a texel) and the tiles cut out of the result (4) are
    // held beside what the map's own height needs.
    if (!host::device_memory(*host::ComputeContext::acquire("auto")).host_unified) {
        WARN("the device's buffers are not host memory: RELIEF_MEMORY_LIMIT does not hold them");
        return;
    }
    const OIIO::ImageBuf whole = whole_map();
    const Set s = set_of(whole);
    const HeightOptions o = with_boundary(Boundary::Free);
    const double plain = test::options::smallest_memory_limit([&] {
        OIIO::ImageBuf out;
        return relief::height(out, whole, o);
    });
    const double set = test::options::smallest_memory_limit([&] {
        std::vector<OIIO::ImageBuf> out;
        return height_udim(out, s.tiles(), o);
    });
    const double texels = double(2 * kW) * (2 * kH);
    INFO("the map " << plain / texels << " bytes a texel, the set " << set / texels);
    CHECK(set - plain >= 8.0 * texels);
}

// SPDX-License-Identifier: Apache-2.0
// relief::height_udim — a UDIM set integrated as one surface, or tile by
// tile, or joined where its tiles meet (docs/design.md §4.4.2: the mask path).
#include "relief/udim.h"

#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "height_memory.h"
#include "relief/slopes.h"
#include "results.h"
#include "poisson/tiling.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ImageSpec;
using OIIO::ROI;

namespace {

int tile_u(int number)
{
    return (number - 1001) % 10;
}
int tile_v(int number)
{
    return (number - 1001) / 10;
}

std::string listed(const std::vector<int>& numbers)
{
    std::string s;
    for (int n : numbers)
        s += (s.empty() ? "" : ",") + std::to_string(n);
    return s;
}

// Tile numbers in range and each once; returns the index of each number.
std::map<int, std::size_t> index_tiles(const std::vector<UdimTile>& tiles)
{
    if (tiles.empty())
        throw std::invalid_argument("a UDIM set needs at least one tile");
    std::map<int, std::size_t> at;
    for (std::size_t i = 0; i < tiles.size(); ++i) {
        const int n = tiles[i].number;
        if (n < 1001 || n > 1999)
            throw std::invalid_argument("UDIM tile numbers run from 1001 to 1999, got " + std::to_string(n));
        if (!tiles[i].normals)
            throw std::invalid_argument("UDIM tile " + std::to_string(n) + " has no image");
        if (!at.emplace(n, i).second)
            throw std::invalid_argument("UDIM tile " + std::to_string(n) + " is given twice");
    }
    return at;
}

// Where a group's tiles lie: the bounding box of their u, v; v runs up, so
// the highest v is the canvas's top row of tiles.
struct Canvas {
    int u0 = 0, v1 = 0, nu = 0, nv = 0;  // first u, last v, tiles across and down
    int w = 0, h = 0;                    // one tile's texels
    int width() const { return nu * w; }
    int height() const { return nv * h; }
    ROI tile_roi(int number, int nch) const
    {
        const int x = (tile_u(number) - u0) * w, y = (v1 - tile_v(number)) * h;
        return ROI(x, x + w, y, y + h, 0, 1, 0, nch);
    }
};

Canvas canvas_of(const std::vector<int>& group, const std::vector<UdimTile>& tiles,
                 const std::map<int, std::size_t>& at)
{
    const ImageSpec& first = tiles[at.at(group.front())].normals->spec();
    int u0 = 9, u1 = 0, v0 = 99, v1 = 0;
    for (int n : group) {
        const ImageSpec& s = tiles[at.at(n)].normals->spec();
        if (s.width != first.width || s.height != first.height || s.nchannels != first.nchannels ||
            s.format != first.format)
            throw std::invalid_argument("UDIM tiles solved together must match: tile " + std::to_string(n) +
                                        " is " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                                        ", " + std::to_string(s.nchannels) + " channel(s) of " +
                                        s.format.c_str() + ", tile " + std::to_string(group.front()) + " " +
                                        std::to_string(first.width) + "x" + std::to_string(first.height) +
                                        ", " + std::to_string(first.nchannels) + " of " +
                                        first.format.c_str() + " (udim=each solves them apart)");
        u0 = std::min(u0, tile_u(n));
        u1 = std::max(u1, tile_u(n));
        v0 = std::min(v0, tile_v(n));
        v1 = std::max(v1, tile_v(n));
    }
    Canvas c;
    c.u0 = u0;
    c.v1 = v1;
    c.nu = u1 - u0 + 1;
    c.nv = v1 - v0 + 1;
    c.w = first.width;
    c.h = first.height;
    return c;
}

// The slopes of one tile on the host (gx, gy per texel), for the edge test.
std::vector<float> host_slopes(const ImageBuf& normals, const HeightOptions& o)
{
    SlopeOptions so;
    so.normals = o.normals;
    so.exec.device = o.exec.device;  // (its messages are the height's to give)
    ImageBuf g = relief::slopes(normals, so);
    if (g.has_error())
        throw std::runtime_error(g.geterror());
    std::vector<float> v(std::size_t(g.spec().width) * g.spec().height * 2);
    if (!g.get_pixels(g.roi(), OIIO::TypeDesc::FLOAT, v.data()))
        throw std::runtime_error("cannot read a tile's slopes: " + g.geterror());
    return v;
}

// The wrap-seam slope test across the edge where `a` meets `b`: the two
// tiles laid out so that the edge is the composite's wrap seam ([b|a] for a
// left of b; a's rows above b's for a below b, since b's bottom row meets
// a's top row).
UdimEdge test_edge(int a, int b, const std::vector<float>& ga, const std::vector<float>& gb, int w, int h)
{
    const bool across = tile_v(a) == tile_v(b);
    std::vector<float> both(ga.size() * 2);
    if (across) {
        for (int y = 0; y < h; ++y) {
            std::copy_n(gb.begin() + std::size_t(y) * w * 2, w * 2, both.begin() + std::size_t(y) * w * 4);
            std::copy_n(ga.begin() + std::size_t(y) * w * 2, w * 2,
                        both.begin() + std::size_t(y) * w * 4 + w * 2);
        }
    } else {
        std::copy(ga.begin(), ga.end(), both.begin());
        std::copy(gb.begin(), gb.end(), both.begin() + ga.size());
    }
    const host::TilingEvidence e = host::tiling_evidence(both.data(), across ? 2 * w : w, across ? h : 2 * h);
    const host::AxisEvidence& axis = across ? e.x : e.y;
    UdimEdge edge;
    edge.a = a;
    edge.b = b;
    edge.joined = axis.slopes_tile;
    edge.seam = axis.seam;
    edge.adjacent = axis.adjacent;
    return edge;
}

// Groups of tiles joined by `edges` (union-find), each ascending, ordered by
// their first tile.
std::vector<std::vector<int>> groups_of(const std::map<int, std::size_t>& at,
                                        const std::vector<UdimEdge>& edges)
{
    std::map<int, int> parent;
    for (const auto& [n, i] : at)
        parent[n] = n;
    const auto root = [&](int n) {
        while (parent[n] != n)
            n = parent[n] = parent[parent[n]];
        return n;
    };
    for (const UdimEdge& e : edges)
        if (e.joined)
            parent[std::max(root(e.a), root(e.b))] = std::min(root(e.a), root(e.b));
    std::map<int, std::vector<int>> by_root;
    for (const auto& [n, i] : at)
        by_root[root(n)].push_back(n);
    std::vector<std::vector<int>> groups;
    for (auto& [r, g] : by_root)
        groups.push_back(std::move(g));
    return groups;
}

// One group solved on its canvas; its tiles' results go to dst[at[n]].
void solve_group(std::vector<ImageBuf>& dst, const std::vector<int>& group,
                 const std::vector<UdimTile>& tiles, const std::map<int, std::size_t>& at,
                 const HeightOptions& options)
{
    const Canvas c = canvas_of(group, tiles, at);
    const ImageBuf& first = *tiles[at.at(group.front())].normals;
    const int nch = first.spec().nchannels;
    const bool full = int(group.size()) == c.nu * c.nv;
    std::vector<int> missing;
    for (int v = c.v1; v > c.v1 - c.nv; --v)
        for (int u = c.u0; u < c.u0 + c.nu; ++u)
            if (!std::binary_search(group.begin(), group.end(), 1001 + u + 10 * v))
                missing.push_back(1001 + u + 10 * v);
    std::sort(missing.begin(), missing.end());
    if (!full && options.method == HeightMethod::Rays)
        throw std::invalid_argument("method=rays joins only a full rectangle of UDIM tiles (" +
                                    listed(missing) + " missing from " + listed(group) +
                                    "); use method=poisson or udim=each");
    if (!full && options.highpass > 0.0f)
        throw std::invalid_argument("the tiles missing from the set's rectangle (" + listed(missing) +
                                    ") are masked out, and highpass does not take a mask yet; use "
                                    "udim=each or give every tile");

    // Memory first: the canvas of normals, the weights, the tiles cut out.
    const std::uint64_t n = std::uint64_t(c.width()) * std::uint64_t(c.height());
    HeightOptions o = options;
    o.udim = UdimMode::Each;       // (the canvas is one map)
    o.exec.on_progress = nullptr;  // (a group's progress is no fraction of the set's)
    ImageBuf mask;                 // weight 0 on missing tiles, unless the alpha is the mask
    if (!full && !o.mask_alpha)
        o.mask = &mask;
    detail::check_height_memory(o, c.width(), c.height(),
                                n * nch * first.spec().format.size() + (o.mask ? 4 * n : 0) + 4 * n);

    ImageSpec spec(c.width(), c.height(), nch, first.spec().format);
    ImageBuf normals(spec);
    if (!full) {
        // Missing tiles hold flat normals (no slopes to count or to clamp)
        // with alpha 0; their weight is 0 in any case.
        const bool is_float = spec.format.is_floating_point();
        const float mid = is_float && o.normals.float_encoding == FloatEncoding::Signed ? 0.0f : 0.5f;
        std::vector<float> flat(nch, mid);
        if (nch >= 3)
            flat[2] = 1.0f;
        if (nch >= 4)
            flat[3] = 0.0f;
        if (!OIIO::ImageBufAlgo::fill(normals, flat))
            throw std::runtime_error("cannot fill the UDIM canvas: " + normals.geterror());
        if (o.mask) {
            mask.reset(ImageSpec(c.width(), c.height(), 1, OIIO::TypeDesc::FLOAT));
            if (!OIIO::ImageBufAlgo::zero(mask))
                throw std::runtime_error("cannot make the UDIM weights: " + mask.geterror());
        }
    }
    for (int t : group) {
        const ImageBuf& tile = *tiles[at.at(t)].normals;
        const ROI r = c.tile_roi(t, nch);
        if (!OIIO::ImageBufAlgo::paste(normals, r.xbegin, r.ybegin, 0, 0, tile, tile.roi()))
            throw std::runtime_error("cannot place UDIM tile " + std::to_string(t) + ": " +
                                     normals.geterror());
        if (mask.initialized()) {
            ROI m = r;
            m.chend = 1;
            if (!OIIO::ImageBufAlgo::fill(mask, {1.0f}, m))
                throw std::runtime_error("cannot make the UDIM weights: " + mask.geterror());
        }
    }
    detail::say(options.exec, Severity::Notice,
                "udim: " + listed(group) + " solved as one surface (" + std::to_string(c.nu) + "x" +
                    std::to_string(c.nv) + " tiles, " + std::to_string(c.width()) + "x" +
                    std::to_string(c.height()) + " texels" +
                    (missing.empty() ? std::string() : ", " + listed(missing) + " missing, weighted 0") +
                    ")");
    ImageBuf result;
    if (!relief::height(result, normals, o))
        throw std::runtime_error(result.geterror());
    normals.clear();

    // Each tile: its part of the canvas, at the tile's own origin.
    std::string parameters = result.spec().get_string_attribute("relief:parameters");
    if (mask.initialized())
        if (const auto at_mask = parameters.find(" mask=image"); at_mask != std::string::npos)
            parameters.erase(at_mask, 11);  // (the weights are the set's shape, not the user's mask)
    for (int t : group) {
        const ImageBuf& tile = *tiles[at.at(t)].normals;
        ImageSpec s = result.spec();
        const ROI from = c.tile_roi(t, 1);
        s.x = tile.spec().x;
        s.y = tile.spec().y;
        s.width = s.full_width = c.w;
        s.height = s.full_height = c.h;
        s.full_x = s.x;
        s.full_y = s.y;
        s.attribute("relief:parameters", parameters);
        s.attribute("relief:udim", group.size() == 1 ? std::string("alone") : "joint " + listed(group));
        ImageBuf out(s);
        if (!result.get_pixels(from, OIIO::TypeDesc::FLOAT, out.localpixels()))
            throw std::runtime_error("cannot cut UDIM tile " + std::to_string(t) +
                                     " out: " + result.geterror());
        dst[at.at(t)] = std::move(out);
    }
}

}  // namespace

std::vector<ImageBuf> height_udim(const std::vector<UdimTile>& tiles, const HeightOptions& options,
                                  UdimReport* report)
{
    std::vector<ImageBuf> dst;
    height_udim(dst, tiles, options, report);
    return dst;
}

bool height_udim(std::vector<ImageBuf>& dst, const std::vector<UdimTile>& tiles, const HeightOptions& options,
                 UdimReport* report)
{
    dst.clear();
    try {
        const detail::OperationScope scope(options.exec);
        detail::require_valid(options);
        const std::map<int, std::size_t> at = index_tiles(tiles);
        std::vector<int> numbers;
        for (const auto& [n, i] : at)
            numbers.push_back(n);
        // (A mask image is one tile's: validate() keeps it from udim=joint.)
        const bool alone = options.udim == UdimMode::Each || (options.udim == UdimMode::Auto && options.mask);
        if (options.udim == UdimMode::Auto && options.mask && tiles.size() > 1)
            detail::say(
                options.exec, Severity::Notice,
                "udim: a mask image weights one tile: every tile solved alone (mask=alpha joins them)");
        UdimReport r;
        r.mode = options.udim == UdimMode::Joint ? "joint" : options.udim == UdimMode::Each ? "each" : "auto";
        if (options.udim == UdimMode::Joint) {
            r.groups = {numbers};
        } else if (alone) {
            for (int n : numbers)
                r.groups.push_back({n});
        } else {
            // Every shared edge, joined where its slopes pass the seam test.
            std::map<int, std::vector<float>> g;
            for (int n : numbers)
                g[n] = host_slopes(*tiles[at.at(n)].normals, options);
            for (int a : numbers)
                for (int b : {a + 1, a + 10}) {
                    if (!at.count(b) || (b == a + 1 && tile_u(a) == 9))
                        continue;
                    const ImageSpec &sa = tiles[at.at(a)].normals->spec(),
                                    &sb = tiles[at.at(b)].normals->spec();
                    UdimEdge e;
                    e.a = a;
                    e.b = b;
                    if (sa.width == sb.width && sa.height == sb.height && sa.nchannels == sb.nchannels &&
                        sa.format == sb.format)
                        e = test_edge(a, b, g[a], g[b], sa.width, sa.height);
                    r.edges.push_back(e);
                    detail::say(options.exec, Severity::Info,
                                "udim: edge " + std::to_string(a) + (b == a + 1 ? "|" : "/") +
                                    std::to_string(b) + (e.joined ? " joined" : " cut") +
                                    (e.joined || sa.width == sb.width
                                         ? " (slope correlation across it " +
                                               detail::format_double("%.2f", e.seam) + " vs " +
                                               detail::format_double("%.2f", e.adjacent) +
                                               " between neighbours)"
                                         : std::string(" (the tiles differ in size or type)")));
                }
            r.groups = groups_of(at, r.edges);
            for (const UdimEdge& e : r.edges) {
                const auto same = [&](const std::vector<int>& gr) {
                    return std::binary_search(gr.begin(), gr.end(), e.a) &&
                           std::binary_search(gr.begin(), gr.end(), e.b);
                };
                if (!e.joined && std::any_of(r.groups.begin(), r.groups.end(), same))
                    detail::say(options.exec, Severity::Notice,
                                "udim: edge " + std::to_string(e.a) + "-" + std::to_string(e.b) +
                                    " fails the seam test, but its tiles are joined through others: "
                                    "solved joined across it too");
            }
        }
        std::vector<ImageBuf> out(tiles.size());
        for (const std::vector<int>& group : r.groups) {
            if (group.size() == 1) {
                // Alone: exactly height() of the tile.
                const std::size_t i = at.at(group.front());
                HeightOptions alone = options;
                alone.exec.on_progress = nullptr;  // (a tile's progress is no fraction of the set's)
                if (!relief::height(out[i], *tiles[i].normals, alone))
                    throw std::runtime_error("tile " + std::to_string(group.front()) + ": " +
                                             out[i].geterror());
                if (options.udim != UdimMode::Each)
                    out[i].specmod().attribute("relief:udim", "alone");
            } else {
                solve_group(out, group, tiles, at, options);
            }
        }
        if (report)
            *report = std::move(r);
        dst = std::move(out);
        return true;
    } catch (const std::exception& e) {
        ImageBuf failed;
        detail::fail(failed, "height", e);
        dst.clear();
        return false;
    }
}

}  // namespace relief

// SPDX-License-Identifier: Apache-2.0
// Distortion correction: the polish of the delivered texel-centre mesh (§4.5.3f) and the
// unflipping before it.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <utility>

#include "device/compute_context.h"
#include "correct/correct_grid.h"
#include "correct/correct_stage.h"
#include "correct/correct_stop_rule.h"
#include "reference/correct_reference.h"
#include "relief/correct.h"
#include "relief/errors.h"
#include "support/fields.h"
#include "support/images.h"
#include "correct/correct_test.h"

using namespace relief;
using namespace relief::test::correction;

TEST_CASE("correct: the polish is centre-node iterations on the delivered mesh from the corner means",
          "[correct]")
{
    // Corner nodes deliver each texel the mean of its four corners; the
    // polish then runs the centre-node solver from those means: the golden
    // model's iterate() on the centre grid, `polish` times. Its report holds
    // the delivered mesh's energy before and after.
    using P = host::Periodic;
    for (auto [w, h, periodic] : {std::tuple{24, 16, P(true)}, std::tuple{20, 19, P(false)},
                                  std::tuple{23, 18, P(true, false)}, std::tuple{20, 17, P(false, true)}}) {
        const auto hts = waves(w, h, 1.0, 10);
        const double scale = 0.3;
        auto p = one_iteration(params(scale, periodic, true));
        const auto means = run(hts, w, h, p);
        p.polish = 2;
        host::CorrectReport rep;
        const auto out = run(hts, w, h, p, &rep);
        const ref::CorrectionGrid g = centre_grid(hts, w, h, scale, periodic);
        std::vector<double> c = agreement(means, std::vector<double>(means.size(), 0.0), w, h).device;
        const std::vector<double> start = c;
        const double e_means = ref::total_energy(g, c);
        ref::iterate(g, c);
        ref::iterate(g, c);
        const double e_gold = ref::total_energy(g, c);
        double moved = 0.0;  // the golden polish's largest move
        for (std::size_t k = 0; k < c.size(); ++k)
            moved = std::max(moved, std::abs(c[k] - start[k]));
        const auto [dev, worst, largest] = agreement(out, c, w, h);
        INFO(w << "x" << h << " periodic x " << periodic.x << " y " << periodic.y << ": delivered energy "
               << e_means << " -> " << e_gold << " (device " << rep.polish.energy_start << " -> "
               << rep.polish.energy_end << "); largest polish move " << moved
               << " texels, max |device - golden| " << worst);
        CHECK(moved > 1e-3);
        // Brent's 1% per step, over two iterations (one: 1e-2, as above;
        // Rusticl's llvmpipe, whose built-ins round otherwise: 2.05e-2).
        CHECK(worst <= 3e-2 * moved);
        CHECK(rep.polish.iterations == 2);
        CHECK(e_gold < e_means);
        CHECK(std::abs(rep.polish.energy_start - e_means) <= 1e-5 * e_means);
        CHECK(std::abs(rep.polish.energy_end - e_gold) <= 1e-4 * e_gold);
        CHECK(std::abs(ref::total_energy(g, dev) - e_gold) <= 1e-4 * e_gold);
        CHECK(rep.polish.seconds > 0.0);
    }
    // Centre nodes deliver their own mesh: nothing to polish.
    host::CorrectReport rep;
    const auto hts = waves(24, 16, 1.0, 10);
    auto p = one_iteration(params(0.3, true, false));
    const auto plain = run(hts, 24, 16, p);
    p.polish = 2;
    CHECK(run(hts, 24, 16, p, &rep) == plain);
    CHECK(rep.polish.iterations == 0);
}

namespace {

// Texture-space areas of every triangle of a centre grid (offsets in
// texels), written out from node positions: the flipped ones' codes (2 x
// owner + 0 for [p, p+(1,0), p+(1,-1)], 1 for [p, p+(1,-1), p+(0,-1)]).
std::vector<long long> flipped_by_positions(const std::vector<float>& c, int w, int h,
                                            host::Periodic periodic)
{
    std::vector<long long> out;
    const auto pos = [&](int i, int j, double& x, double& y) {
        if ((!periodic.x && (i < 0 || i >= w)) || (!periodic.y && (j < 0 || j >= h)))
            return false;
        const int wi = (i + w) % w, wj = (j + h) % h;
        x = i + c[2 * (std::size_t(wj) * w + wi)];
        y = j + c[2 * (std::size_t(wj) * w + wi) + 1];
        return true;
    };
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            for (int t = 0; t < 2; ++t) {
                double px, py, ax, ay, bx, by;
                const bool ok = pos(i, j, px, py) && pos(i + 1, j - (t == 0 ? 0 : 1), ax, ay) &&
                                pos(i + (t == 0 ? 1 : 0), j - 1, bx, by);
                if (ok && !((ay - py) * (bx - px) - (ax - px) * (by - py) > 0.0))
                    out.push_back(2 * (std::size_t(j) * w + i) + t);
            }
    return out;
}

// A smooth field of offsets (texels) with two folds: one node pushed past
// its right neighbour, and a pair pushed through each other.
std::vector<float> folded_offsets(int w, int h)
{
    std::vector<float> c(2 * std::size_t(w) * h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            c[2 * (std::size_t(j) * w + i)] = float(0.2 * std::sin(6.283 * i / w) * std::cos(6.283 * j / h));
            c[2 * (std::size_t(j) * w + i) + 1] = float(0.15 * std::cos(6.283 * i / w));
        }
    c[2 * (std::size_t(5) * w + 6)] += 1.6f;
    c[2 * (std::size_t(5) * w + 6) + 1] += 0.3f;
    c[2 * (std::size_t(8) * w + 10)] += 1.2f;
    c[2 * (std::size_t(8) * w + 11)] -= 1.1f;
    c[2 * (std::size_t(3) * w + 1)] -= 1.6f;  // past the left border's node
    return c;
}

}  // namespace

TEST_CASE("correct: unflip_mesh mends folds and leaves the rest of the mesh", "[correct]")
{
    using P = host::Periodic;
    for (auto [w, h, periodic] : {std::tuple{20, 14, P(true)}, std::tuple{19, 13, P(false)},
                                  std::tuple{20, 13, P(true, false)}, std::tuple{19, 14, P(false, true)}}) {
        const host::NodeGrid g(w, h, false, periodic);
        std::vector<float> c = folded_offsets(w, h);
        const std::vector<float> start = c;
        const auto before = flipped_by_positions(c, w, h, periodic);
        INFO(w << "x" << h << " periodic x " << periodic.x << " y " << periodic.y << ": " << before.size()
               << " flipped");
        CHECK(before.size() >= 4);
        CHECK(host::flipped_triangles(c, g) == before);
        const int moves = host::unflip_mesh(c, g, 20);
        CHECK(moves > 0);
        CHECK(flipped_by_positions(c, w, h, periodic).empty());
        CHECK(host::flipped_triangles(c, g).empty());
        // Only nodes near the folds moved (within 4 rings of their
        // triangles' corners), never a pinned border node.
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const std::size_t k = 2 * (std::size_t(j) * w + i);
                const bool moved = c[k] != start[k] || c[k + 1] != start[k + 1];
                const bool pinned =
                    (!periodic.x && (i == 0 || i == w - 1)) || (!periodic.y && (j == 0 || j == h - 1));
                // Distances wrap along a periodic axis.
                const auto dist = [&](double a, double b, int n, bool wraps) {
                    const double d = std::abs(a - b);
                    return wraps ? std::min(d, n - d) : d;
                };
                const auto near_to = [&](double x, double y, double r) {
                    return dist(i, x, w, periodic.x) <= r && dist(j, y, h, periodic.y) <= 5;
                };
                const bool near = near_to(6, 5, 5) || near_to(10.5, 8, 5.5) || near_to(1, 3, 5);
                if (pinned || !near) {
                    INFO("node " << i << ", " << j);
                    CHECK_FALSE(moved);
                }
            }
        // An unfolded mesh is left alone.
        std::vector<float> smooth = folded_offsets(w, h);
        smooth[2 * (std::size_t(5) * w + 6)] -= 1.6f;
        smooth[2 * (std::size_t(5) * w + 6) + 1] -= 0.3f;
        smooth[2 * (std::size_t(8) * w + 10)] -= 1.2f;
        smooth[2 * (std::size_t(8) * w + 11)] += 1.1f;
        smooth[2 * (std::size_t(3) * w + 1)] += 1.6f;
        const std::vector<float> kept = smooth;
        CHECK(host::flipped_triangles(smooth, g).empty());
        CHECK(host::unflip_mesh(smooth, g, 20) == 0);
        CHECK(smooth == kept);
    }
}

TEST_CASE("correct: unflip_mesh moves a node straight back, by the first quarter step that mends",
          "[correct]")
{
    // 3 x 3 nodes, fixed: only the centre moves, back toward its
    // neighbours' mean (0, 0) by quarters. Pushed by (1.2, 1.2) texels,
    // past its fan's edge x + y = 1, 0.9 and 0.6 of the way still fold and
    // 0.3 does not; by (1.2, -0.5), past its own triangle's edge x = 1, a
    // quarter of the way mends it.
    const host::NodeGrid g(3, 3, false, host::Periodic(false));
    for (const auto& [x0, y0, t] : {std::tuple{1.2f, 1.2f, 0.75}, std::tuple{1.2f, -0.5f, 0.25}}) {
        INFO("pushed by " << x0 << ", " << y0);
        std::vector<float> c(2 * 9, 0.0f);
        c[2 * 4] = x0;
        c[2 * 4 + 1] = y0;
        REQUIRE(host::flipped_triangles(c, g).size() > 0);
        CHECK(host::unflip_mesh(c, g, 20) == 1);
        CHECK(host::flipped_triangles(c, g).empty());
        CHECK(c[2 * 4] == float(x0 + t * (0.0 - x0)));
        CHECK(c[2 * 4 + 1] == float(y0 + t * (0.0 - y0)));
        // The whole mesh shifted by (0.3, 0.2): the same fold, the same
        // step, now toward the neighbours' mean (0.3, 0.2).
        std::vector<float> shifted(2 * 9);
        for (std::size_t k = 0; k < 9; ++k) {
            shifted[2 * k] = 0.3f;
            shifted[2 * k + 1] = 0.2f;
        }
        shifted[2 * 4] += x0;
        shifted[2 * 4 + 1] += y0;
        const double sx = shifted[2 * 4], sy = shifted[2 * 4 + 1];
        CHECK(host::unflip_mesh(shifted, g, 20) == 1);
        CHECK(host::flipped_triangles(shifted, g).empty());
        CHECK(shifted[2 * 4] == Approx(sx + t * (double(0.3f) - sx)).margin(1e-6));
        CHECK(shifted[2 * 4 + 1] == Approx(sy + t * (double(0.2f) - sy)).margin(1e-6));
    }
}

TEST_CASE("correct: unflip_mesh takes a fold no quarter step mends to the point deepest in its fan",
          "[correct]")
{
    // 3 x 3 nodes, fixed: only the centre moves. Its pinned neighbours'
    // offsets leave a fan whose inside neither the way to their mean nor the
    // way back to the centre's own place reaches, so the centre goes to the
    // point farthest inside its fan's edges. A 0.01-texel lattice bounds how
    // far that is.
    const host::NodeGrid g(3, 3, false, host::Periodic(false));
    std::vector<float> c(2 * 9, 0.0f);
    const auto set = [&](int i, int j, float x, float y) {
        c[2 * (3 * j + i)] = x;
        c[2 * (3 * j + i) + 1] = y;
    };
    set(1, 0, 0.6f, 0.2f);
    set(2, 0, -0.4f, -0.5f);
    set(2, 1, 0.2f, -0.1f);
    set(1, 2, 0.3f, -0.6f);
    set(0, 2, 0.6f, -0.1f);
    set(0, 1, -0.1f, 0.4f);
    set(1, 1, 0.5f, -0.3f);
    REQUIRE(host::flipped_triangles(c, g).size() >= 1);
    // The least distance from (x, y) to the lines through consecutive
    // neighbours of the centre, negative outside.
    const auto depth = [&](double x, double y) {
        static const int kFan[6][2] = {{1, 0}, {2, 0}, {2, 1}, {1, 2}, {0, 2}, {0, 1}};
        double d = 1e300;
        for (int k = 0; k < 6; ++k) {
            const int *a = kFan[(k + 1) % 6], *b = kFan[k];
            const double ax = a[0] + c[2 * (3 * a[1] + a[0])], ay = a[1] + c[2 * (3 * a[1] + a[0]) + 1];
            const double bx = b[0] + c[2 * (3 * b[1] + b[0])], by = b[1] + c[2 * (3 * b[1] + b[0]) + 1];
            d = std::min(d, ((ay - y) * (bx - x) - (ax - x) * (by - y)) / std::hypot(ax - bx, ay - by));
        }
        return d;
    };
    double lattice = -1e300;
    for (int j = -300; j <= 300; ++j)
        for (int i = -300; i <= 300; ++i)
            lattice = std::max(lattice, depth(1 + 0.01 * i, 1 + 0.01 * j));
    REQUIRE(depth(1.5, 0.7) < 0.0);
    REQUIRE(lattice > 0.2);
    CHECK(host::unflip_mesh(c, g, 20) == 1);
    CHECK(host::flipped_triangles(c, g).empty());
    const double got = depth(1 + c[8], 1 + c[9]);
    INFO("the centre at " << c[8] << ", " << c[9] << ": " << got << " texels inside, the lattice's best "
                          << lattice);
    CHECK(got >= lattice - 1e-4);
    CHECK(got <= lattice + 1e-2);
}

TEST_CASE("correct: the polish unflips the delivered mesh before its iterations", "[correct]")
{
    // Texel offsets with folds (as a cliff's corner means can hold): the
    // polish unflips them, then its iterations lower a finite energy.
    using P = host::Periodic;
    for (auto [w, h, periodic] : {std::tuple{20, 14, P(true)}, std::tuple{19, 13, P(false)}}) {
        const auto hts = waves(w, h, 1.0, 10);
        auto p = params(0.3, periodic);
        p.polish = 2;
        std::vector<float> c = folded_offsets(w, h);
        for (std::size_t k = 0; k < c.size(); k += 2) {
            c[k] /= float(w);
            c[k + 1] /= float(h);
        }
        auto ctx = host::ComputeContext::acquire("auto");
        const host::CorrectPolish r = host::polish_delivered_mesh(*ctx, hts, {}, w, h, p, c);
        INFO(w << "x" << h << ": " << r.flipped << " flipped, " << r.repairs << " moves, " << r.flipped_left
               << " left; energy " << r.energy_start << " -> " << r.energy_end);
        CHECK(r.flipped >= 4);
        CHECK(r.repairs > 0);
        CHECK(r.flipped_left == 0);
        CHECK(std::isfinite(r.energy_start));
        CHECK(r.energy_end < r.energy_start);
        CHECK(r.iterations == 2);
        std::vector<float> texels(c.size());
        for (std::size_t k = 0; k < c.size(); k += 2) {
            texels[k] = c[k] * float(w);
            texels[k + 1] = c[k + 1] * float(h);
        }
        CHECK(flipped_by_positions(texels, w, h, periodic).empty());
        const ref::CorrectionGrid g = centre_grid(hts, w, h, 0.3, periodic);
        const double e = ref::total_energy(g, agreement(c, std::vector<double>(c.size(), 0.0), w, h).device);
        CHECK(e == Approx(r.energy_end).epsilon(1e-4));
    }
}

// SPDX-License-Identifier: Apache-2.0
// Least-squares (Poisson) integration: the device solver against the double
// golden model and against analytic truth.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <utility>

#include "device/compute_context.h"
#include "poisson/poisson_stage.h"
#include "reference/poisson_reference.h"
#include "reference/zero_mean.h"
#include "slopes/slope_stage.h"
#include "support/fields.h"
#include "support/images.h"
#include "poisson/tiling.h"

using namespace relief;

namespace {

// Per axis: periodic or free.
struct Axes {
    bool x, y;
};

std::vector<float> solve(const std::vector<double>& g, int w, int h, Axes periodic, double highpass = 0.0)
{
    auto ctx = host::ComputeContext::acquire("auto");
    std::vector<float> gf(g.begin(), g.end());
    auto slopes = host::upload_slopes(*ctx, gf.data(), w, h);
    host::PoissonParams p;
    const auto boundary = [](bool b) {
        return b ? host::PoissonBoundary::Periodic : host::PoissonBoundary::Free;
    };
    p.boundary_x = boundary(periodic.x);
    p.boundary_y = boundary(periodic.y);
    p.highpass = highpass;
    std::vector<float> out(std::size_t(w) * h);
    host::integrate_poisson(*ctx, slopes, p, out.data());
    return out;
}

template <class A>
double spread(const A& a)
{
    double lo = 1e300, hi = -1e300;
    for (auto v : a) {
        lo = std::min(lo, double(v));
        hi = std::max(hi, double(v));
    }
    return hi - lo;
}

template <class A, class B>
double rmse(const A& a, const B& b)
{
    double s = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        s += (double(a[i]) - double(b[i])) * (double(a[i]) - double(b[i]));
    return std::sqrt(s / double(a.size()));
}

}  // namespace

namespace {

// Every boundary (both axes the same, and one periodic axis with one free:
// the FFT along one, the DCT along the other; solved transposed when y is
// the periodic one), with and without a highpass, against the golden model.
void check_poisson_golden(int w, int h)
{
    for (Axes periodic : {Axes{true, true}, Axes{false, false}, Axes{true, false}, Axes{false, true}})
        for (double highpass : {0.0, 8.0}) {
            INFO(w << "x" << h << " x " << (periodic.x ? "periodic" : "free") << ", y "
                   << (periodic.y ? "periodic" : "free") << ", highpass " << highpass);
            auto g = test::rough_slopes(w, h, 3u + w);
            reference::PoissonSettings s;
            s.periodic_x = periodic.x;
            s.periodic_y = periodic.y;
            s.highpass_sigma = host::highpass_sigma(highpass);
            auto ref = reference::poisson(g, w, h, s);
            auto got = solve(g, w, h, periodic, highpass);
            INFO("max diff " << test::max_abs_diff(got, ref) << ", spread " << spread(ref));
            CHECK(test::max_abs_diff(got, ref) <= 1e-4 * spread(ref) + 1e-6);
        }
}

}  // namespace

// Odd lengths of small primes (the fast tier's size, shared with the
// weighted solver's test, so that its FFTs are planned once; prime lengths,
// which VkFFT does by Bluestein's algorithm and which cost 2x the cold
// kernel builds, and even lengths are in the stress label).
TEST_CASE("Poisson solver equals the double-precision golden model", "[poisson]")
{
    check_poisson_golden(35, 27);
    // One row and one column (a layout of its own), at the lengths above.
    check_poisson_golden(35, 1);
    check_poisson_golden(1, 27);
}

TEST_CASE("Poisson solver equals the double-precision golden model at prime, even, thin and tiny sizes",
          "[poisson][stress]")
{
    for (const auto& [w, h] :
         {std::pair{30, 33}, {24, 24}, {31, 7}, {2, 3}, {1, 17}, {17, 1}, {64, 40}, {5, 2}})
        check_poisson_golden(w, h);
}

TEST_CASE("a 1x1 texture integrates to zero", "[poisson]")
{
    for (bool periodic : {true, false})
        CHECK(solve({0.3, -0.2}, 1, 1, {periodic, !periodic})[0] == 0.0f);
}

TEST_CASE("periodic: band-limited fields are recovered exactly", "[poisson]")
{
    const test::PeriodicField f{
        256, 192, {{1, 0, 4.0, 0.2}, {3, 2, 2.0, 1.0}, {-7, 5, 0.5, 2.5}, {20, -11, 0.1, 0.3}}};
    auto got = solve(f.slopes(), f.width, f.height, {true, true});
    std::vector<double> truth(got.size());
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x)
            truth[std::size_t(y) * f.width + x] = f.h(x, y);
    relief::reference::subtract_mean(truth);
    const double rel = rmse(got, truth) / spread(truth);
    INFO("RMSE / spread = " << rel);
    CHECK(rel <= 1e-4);
}

TEST_CASE("free: fields with zero normal slope at the edges are recovered exactly", "[poisson]")
{
    // h = sum a cos(pi k (x + 1/2) / W) cos(pi l (y + 1/2) / H): a non-tiling
    // field (odd k or l) whose even extension is smooth.
    const int w = 256, h = 192;  // (the periodic test's size: its FFTs planned once)
    struct Term {
        int k, l;
        double a;
    };
    const Term terms[] = {{1, 0, 3.0}, {1, 1, 2.0}, {3, 2, 1.0}, {9, 4, 0.2}, {0, 5, 0.4}};
    std::vector<double> g(2 * std::size_t(w) * h), truth(std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = std::size_t(y) * w + x;
            for (const Term& t : terms) {
                const double wx = M_PI * t.k / w, wy = M_PI * t.l / h;
                const double cx = std::cos(wx * (x + 0.5)), cy = std::cos(wy * (y + 0.5));
                truth[i] += t.a * cx * cy;
                g[2 * i] += -t.a * wx * std::sin(wx * (x + 0.5)) * cy;
                g[2 * i + 1] += -t.a * wy * cx * std::sin(wy * (y + 0.5));
            }
        }
    relief::reference::subtract_mean(truth);
    auto got = solve(g, w, h, {false, false});
    const double rel = rmse(got, truth) / spread(truth);
    INFO("RMSE / spread = " << rel);
    CHECK(rel <= 1e-4);
}

TEST_CASE("one periodic axis, one free: fields that tile along one axis only are recovered exactly",
          "[poisson][slow]")
{
    // h = sum a cos(2 pi k u / U + phase) cos(pi l (v + 1/2) / V): periodic
    // along u, and along v a cosine series whose even extension is smooth
    // (odd l: the two edges differ, so v does not tile). u is x, then y.
    struct Term {
        int k, l;
        double a, phase;
    };
    const Term terms[] = {
        {1, 1, 3.0, 0.3}, {2, 0, 1.0, 1.1}, {0, 3, 1.5, 0.0}, {5, 2, 0.3, 2.0}, {-3, 7, 0.2, 0.5}};
    const int nu = 96, nv = 70;
    for (bool u_is_x : {true, false}) {
        const int w = u_is_x ? nu : nv, h = u_is_x ? nv : nu;
        std::vector<double> g(2 * std::size_t(w) * h), truth(std::size_t(w) * h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const std::size_t i = std::size_t(y) * w + x;
                const int u = u_is_x ? x : y, v = u_is_x ? y : x;
                for (const Term& t : terms) {
                    const double wu = 2.0 * M_PI * t.k / nu, wv = M_PI * t.l / nv;
                    const double cu = std::cos(wu * u + t.phase), cv = std::cos(wv * (v + 0.5));
                    const double du = -t.a * wu * std::sin(wu * u + t.phase) * cv;
                    const double dv = -t.a * wv * cu * std::sin(wv * (v + 0.5));
                    truth[i] += t.a * cu * cv;
                    g[2 * i] += u_is_x ? du : dv;
                    g[2 * i + 1] += u_is_x ? dv : du;
                }
            }
        relief::reference::subtract_mean(truth);
        const Axes right = u_is_x ? Axes{true, false} : Axes{false, true};
        INFO((u_is_x ? "periodic along x, free along y" : "free along x, periodic along y"));
        const double rel = rmse(solve(g, w, h, right), truth) / spread(truth);
        INFO("RMSE / spread = " << rel);
        CHECK(rel <= 1e-4);
        // Either single boundary for both axes misses it.
        for (bool both : {true, false}) {
            const double other = rmse(solve(g, w, h, {both, both}), truth) / spread(truth);
            INFO((both ? "both periodic" : "both free") << ": RMSE / spread = " << other);
            CHECK(other >= 100.0 * rel);
        }
    }
}

TEST_CASE("highpass removes long wavelengths and keeps short ones", "[poisson]")
{
    // Wavelengths 256 and 8 texels; highpass=32 halves wavelength 32.
    const test::PeriodicField longw{256, 256, {{1, 0, 5.0, 0.0}}};
    const test::PeriodicField shortw{256, 256, {{32, 0, 1.0, 0.0}}};
    auto a = solve(longw.slopes(), 256, 256, {true, true}, 32.0);
    auto b = solve(shortw.slopes(), 256, 256, {true, true}, 32.0);
    auto gain = [](double wavelength) {
        const double w = 2 * M_PI / wavelength, s = host::highpass_sigma(32.0);
        return 1.0 - std::exp(-0.5 * w * w * s * s);
    };
    CHECK(std::abs(gain(32.0) - 0.5) < 1e-12);
    CHECK(spread(a) == Approx(10.0 * gain(256.0)).epsilon(1e-3));  // ~0.011 of the wave left
    CHECK(spread(b) == Approx(2.0 * gain(8.0)).epsilon(1e-3));     // ~all of it kept
}

TEST_CASE("tiling evidence: a periodic field tiles, a crop of one does not", "[poisson][tiling]")
{
    const test::PeriodicField f{192, 160, {{3, 1, 4.0, 0.2}, {5, -4, 1.0, 1.0}, {11, 7, 0.3, 2.5}}};
    auto g = f.slopes();
    std::vector<float> gf(g.begin(), g.end());
    auto e = host::tiling_evidence(gf.data(), f.width, f.height);
    CHECK(e.tiles);
    // The left 120 x 100 texels: the seams join unrelated columns and rows.
    const int w = 120, h = 100;
    std::vector<float> crop(2 * std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 2; ++c)
                crop[2 * (std::size_t(y) * w + x) + c] = gf[2 * (std::size_t(y) * f.width + x) + c];
    auto c = host::tiling_evidence(crop.data(), w, h);
    INFO("x " << c.x.seam << " vs " << c.x.adjacent << ", y " << c.y.seam << " vs " << c.y.adjacent);
    CHECK_FALSE(c.tiles);
    // Too small to judge: counts as tiling.
    CHECK(host::tiling_evidence(crop.data(), 2, 2).tiles);
}

namespace {

// The w x h texels from (x0, y0) of slopes g that are `width` texels wide.
std::vector<float> window(const std::vector<double>& g, int width, int x0, int y0, int w, int h)
{
    std::vector<float> out(2 * std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 2; ++c)
                out[2 * (std::size_t(y) * w + x) + c] =
                    float(g[2 * (std::size_t(y + y0) * width + x + x0) + c]);
    return out;
}

// The slopes of the first and last column (row) replaced by noise as strong
// as the slopes: a wrap seam painted over, whose texels no longer correlate.
void paint_over_seam(std::vector<float>& g, int w, int h, bool columns, unsigned seed)
{
    std::mt19937 rng(seed);
    std::normal_distribution<float> noise(0.0f, float(test::rms(g)));
    const int lines = columns ? h : w;
    for (int i = 0; i < lines; ++i)
        for (int e : {0, (columns ? w : h) - 1}) {
            const std::size_t t = columns ? std::size_t(i) * w + e : std::size_t(e) * w + i;
            g[2 * t] = noise(rng);
            g[2 * t + 1] = noise(rng);
        }
}

}  // namespace

TEST_CASE("tiling evidence: slope correlations lie between 0 and 1 and do not depend on the slopes' scale",
          "[poisson][tiling]")
{
    const test::PeriodicField f{96, 80, {{3, 1, 4.0, 0.2}, {5, -4, 1.0, 1.0}}};
    const std::vector<double> g = f.slopes();
    for (const auto& [w, h] : {std::pair{96, 80}, std::pair{60, 50}}) {  // the whole map, a crop
        INFO(w << "x" << h);
        const std::vector<float> a = window(g, 96, 0, 0, w, h);
        std::vector<float> small = a;
        for (float& v : small)
            v *= 1e-3f;
        const auto e = host::tiling_evidence(a.data(), w, h), s = host::tiling_evidence(small.data(), w, h);
        for (const auto& [big, tiny] : {std::pair{e.x, s.x}, std::pair{e.y, s.y}}) {
            CHECK(big.seam >= 0.0);
            CHECK(big.seam <= 1.0 + 1e-9);
            CHECK(big.adjacent <= 1.0 + 1e-9);
            CHECK(tiny.seam == Approx(big.seam).margin(1e-4));
            CHECK(tiny.adjacent == Approx(big.adjacent).margin(1e-4));
        }
    }
}

TEST_CASE("tiling evidence: which lines the seam and the neighbours compare, exactly", "[poisson][tiling]")
{
    // Columns of two kinds, 40 texels a column: A = (cos, sin) of one
    // period down the column, B = A's components swapped, which correlates
    // with A not at all. |r| is 1 between two A's or two B's, 0 between an
    // A and a B; rows of equal columns are constant (no correlation: 0).
    const int h = 40;
    const auto columns = [&](const std::string& kinds) {
        const int w = int(kinds.size());
        std::vector<float> g(2 * std::size_t(w) * h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const float c = float(std::cos(2 * M_PI * y / h)), s = float(std::sin(2 * M_PI * y / h));
                const bool a = kinds[std::size_t(x)] == 'A';
                g[2 * (std::size_t(y) * w + x)] = a ? c : s;
                g[2 * (std::size_t(y) * w + x) + 1] = a ? s : c;
            }
        return host::tiling_evidence(g.data(), w, h);
    };
    // The seam joins the last column to the first, not their neighbours.
    const auto seam = columns("ABAAAAAABA");
    CHECK(seam.x.seam == Approx(1.0).epsilon(1e-6));
    // Neighbours: 64 pairs spread over the lines, from the first to the
    // last pair, here 0-1 ... 62-63 and 64-65 (all alike) but never 63-64.
    const auto spread = columns(std::string(64, 'A') + "BB");
    CHECK(spread.x.adjacent == Approx(1.0).epsilon(1e-6));
    CHECK(spread.x.seam == Approx(0.0).margin(1e-6));
    // Constant lines correlate with nothing: 0, not NaN.
    const auto same = columns(std::string(12, 'A'));
    CHECK(same.y.seam == 0.0);
    CHECK(same.y.adjacent == 0.0);
    CHECK(same.x.seam == Approx(1.0).epsilon(1e-6));
    // Three lines are enough to judge; two are not (and count as tiling).
    CHECK(columns("ABA").x.seam == Approx(1.0).epsilon(1e-6));
    CHECK(columns("AB").x.seam == 0.0);
    CHECK(columns("AB").x.tiles);
}

TEST_CASE("tiling evidence per axis: block heights see a rough seam through, and a crop or one-axis tiling "
          "for what it is",
          "[poisson][tiling]")
{
    // Rough slopes (neighbouring columns correlate about 0.4) on a smooth
    // periodic surface.
    const test::PeriodicField f{384, 320, {{3, 1, 40.0, 0.2}, {5, -4, 10.0, 1.0}, {11, 7, 3.0, 2.5}}};
    const std::vector<double> g = test::plus_noise(f.slopes(), 1.5, 7);
    std::vector<float> whole = window(g, 384, 0, 0, 384, 320);
    auto e = host::tiling_evidence(whole.data(), 384, 320);
    INFO("x: r " << e.x.seam << "/" << e.x.adjacent << " step " << e.x.height_step << "; y: r " << e.y.seam
                 << "/" << e.y.adjacent << " step " << e.y.height_step);
    CHECK(e.x.adjacent < host::kSmoothAdjacent);
    CHECK((e.x.slopes_tile && e.y.slopes_tile && e.x.tiles && e.y.tiles));
    CHECK(e.x.height_step < host::kTilingHeightStep);
    CHECK(e.y.height_step < host::kTilingHeightStep);
    // A tilt (a mean slope, as a normal map's bias gives) is no evidence:
    // every step carries it, the periodic solve drops it.
    std::vector<float> tilted = whole;
    for (std::size_t i = 0; i < tilted.size(); i += 2) {
        tilted[i] += 0.8f;
        tilted[i + 1] -= 0.5f;
    }
    const auto t = host::tiling_evidence(tilted.data(), 384, 320);
    CHECK(t.x.height_step == Approx(e.x.height_step).epsilon(1e-4));
    CHECK(t.y.height_step == Approx(e.y.height_step).epsilon(1e-4));

    // The x seam painted over: the slope test fails it, the block heights
    // still join (the seam carries 2 of 384 columns).
    paint_over_seam(whole, 384, 320, true, 9);
    e = host::tiling_evidence(whole.data(), 384, 320);
    INFO("painted: x r " << e.x.seam << "/" << e.x.adjacent << " step " << e.x.height_step);
    CHECK_FALSE(e.x.slopes_tile);
    CHECK(e.x.tiles);
    CHECK(e.y.tiles);
    CHECK(e.tiles);  // both axes tile: rays on auto take periodic too

    // The left 200 x 170: a crop, neither axis tiles by either test.
    std::vector<float> crop = window(g, 384, 0, 0, 200, 170);
    e = host::tiling_evidence(crop.data(), 200, 170);
    INFO("crop: x r " << e.x.seam << "/" << e.x.adjacent << " step " << e.x.height_step << "; y r "
                      << e.y.seam << "/" << e.y.adjacent << " step " << e.y.height_step);
    CHECK(e.x.height_step > host::kTilingHeightStep);
    CHECK(e.y.height_step > host::kTilingHeightStep);
    CHECK_FALSE(e.x.tiles);
    CHECK_FALSE(e.y.tiles);

    // All 384 columns of 170 rows: tiles along x only.
    std::vector<float> band = window(g, 384, 0, 75, 384, 170);
    e = host::tiling_evidence(band.data(), 384, 170);
    INFO("band: x step " << e.x.height_step << "; y step " << e.y.height_step);
    CHECK(e.x.tiles);
    CHECK_FALSE(e.y.tiles);
    CHECK_FALSE(e.tiles);  // rays on auto take one boundary: clip
}

TEST_CASE("tiling evidence per axis: on a smooth map a seam whose slopes do not correlate is a clean break",
          "[poisson][tiling]")
{
    // Smooth slopes (neighbours correlate near 1): a painted-over seam is
    // believed to be a break, whatever the block heights say.
    const test::PeriodicField f{192, 160, {{3, 1, 4.0, 0.2}, {5, -4, 1.0, 1.0}}};
    std::vector<float> g = window(f.slopes(), 192, 0, 0, 192, 160);
    auto e = host::tiling_evidence(g.data(), 192, 160);
    CHECK((e.x.tiles && e.y.tiles));
    paint_over_seam(g, 192, 160, false, 3);
    e = host::tiling_evidence(g.data(), 192, 160);
    INFO("y r " << e.y.seam << "/" << e.y.adjacent << " step " << e.y.height_step);
    CHECK(e.y.adjacent >= host::kSmoothAdjacent);
    CHECK(e.y.height_step < host::kTilingHeightStep);
    CHECK_FALSE(e.y.tiles);
    CHECK(e.x.tiles);

    // Slopes that tile but do not close around the map (a curl across the
    // rows, as authored normal maps have): the block heights step a few
    // times more at the seam than inside, and the slopes are believed.
    std::vector<float> curl = window(f.slopes(), 192, 0, 0, 192, 160);
    for (int y = 0; y < 160; ++y)
        for (int x = 0; x < 192; ++x)
            curl[2 * (std::size_t(y) * 192 + x)] += 0.1f * (float(y) / 160 - 0.5f);
    e = host::tiling_evidence(curl.data(), 192, 160);
    INFO("curl: x r " << e.x.seam << "/" << e.x.adjacent << " step " << e.x.height_step);
    CHECK(e.x.slopes_tile);
    CHECK(e.x.height_step > host::kTilingHeightStep);
    CHECK(e.x.height_step <= host::kSlopesBelievedStep);
    CHECK(e.x.tiles);
}

namespace {

std::vector<float> solve_weighted(const std::vector<double>& g, const std::vector<float>& weights, int w,
                                  int h, Axes periodic, host::PoissonReport* report = nullptr)
{
    auto ctx = host::ComputeContext::acquire("auto");
    std::vector<float> gf(g.begin(), g.end());
    auto slopes = host::upload_slopes(*ctx, gf.data(), w, h);
    host::PoissonParams p;
    p.boundary_x = periodic.x ? host::PoissonBoundary::Periodic : host::PoissonBoundary::Free;
    p.boundary_y = periodic.y ? host::PoissonBoundary::Periodic : host::PoissonBoundary::Free;
    p.weights = weights.data();
    p.tolerance = 1e-6;
    std::vector<float> out(std::size_t(w) * h);
    host::integrate_poisson(*ctx, slopes, p, out.data(), report);
    return out;
}

}  // namespace

namespace {

// Every boundary, a fifth of the texels excluded and the rest partly
// weighted, against the golden model.
void check_weighted_golden(int w, int h)
{
    for (Axes periodic : {Axes{true, true}, Axes{false, false}, Axes{true, false}, Axes{false, true}}) {
        INFO(w << "x" << h << " x " << (periodic.x ? "periodic" : "free") << ", y "
               << (periodic.y ? "periodic" : "free"));
        auto g = test::rough_slopes(w, h, 17u + w);
        std::mt19937 rng(5);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::vector<double> wd(std::size_t(w) * h);
        for (double& v : wd)
            v = u(rng) < 0.2 ? 0.0 : u(rng);  // a fifth excluded, the rest partial
        std::vector<float> wf(wd.begin(), wd.end());
        auto ref = reference::poisson_weighted(g, w, h, wd, periodic.x, periodic.y, 1e-3);
        host::PoissonReport report;
        auto got = solve_weighted(g, wf, w, h, periodic, &report);
        INFO("iterations " << report.iterations << ", residual " << report.residual << ", max diff "
                           << test::max_abs_diff(got, ref) << ", spread " << spread(ref));
        CHECK(report.residual <= 1e-6);
        CHECK(test::max_abs_diff(got, ref) <= 1e-3 * spread(ref) + 1e-6);
    }
}

}  // namespace

TEST_CASE("weighted Poisson equals the double-precision golden model", "[poisson][mask]")
{
    check_weighted_golden(35, 27);
}

TEST_CASE("weighted Poisson equals the double-precision golden model at prime, even, thin and tiny sizes",
          "[poisson][mask][stress]")
{
    for (const auto& [w, h] : {std::pair{37, 29}, {16, 16}, {1, 23}, {23, 1}, {5, 3}})
        check_weighted_golden(w, h);
}

TEST_CASE("a mask keeps corrupt slopes out of the result", "[poisson][mask]")
{
    const test::PeriodicField f{128, 128, {{1, 1, 5.0, 0.3}, {3, -2, 1.0, 1.1}}};
    auto g = f.slopes();
    std::vector<float> weights(std::size_t(f.width) * f.height, 1.0f);
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(0.0, 2.0);
    auto in_hole = [](int x, int y) { return x >= 40 && x < 70 && y >= 30 && y < 55; };
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x)
            if (in_hole(x, y)) {
                const std::size_t i = std::size_t(y) * f.width + x;
                g[2 * i] += noise(rng) + 1.5;  // corrupt, and biased
                g[2 * i + 1] += noise(rng);
                weights[i] = 0.0f;
            }
    auto masked = solve_weighted(g, weights, f.width, f.height, {true, true});
    auto plain = solve(g, f.width, f.height, {true, true});
    // Error outside the hole, after removing the mean offset there.
    auto error = [&](const std::vector<float>& got) {
        double mean = 0;
        std::size_t count = 0;
        for (int y = 0; y < f.height; ++y)
            for (int x = 0; x < f.width; ++x)
                if (!in_hole(x, y)) {
                    mean += got[std::size_t(y) * f.width + x] - f.h(x, y);
                    ++count;
                }
        mean /= double(count);
        double se = 0;
        for (int y = 0; y < f.height; ++y)
            for (int x = 0; x < f.width; ++x)
                if (!in_hole(x, y)) {
                    const double d = got[std::size_t(y) * f.width + x] - f.h(x, y) - mean;
                    se += d * d;
                }
        return std::sqrt(se / double(count)) / 12.0;  // spread of h is about 12
    };
    INFO("RMSE / spread outside the hole: masked " << error(masked) << ", unmasked " << error(plain));
    CHECK(error(masked) < 0.005);
    CHECK(error(plain) > 4 * error(masked));
}

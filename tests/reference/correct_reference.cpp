// SPDX-License-Identifier: Apache-2.0
#include "reference/correct_reference.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace relief::reference {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

int wrap(int v, int n)
{
    v %= n;
    return v < 0 ? v + n : v;
}

Vec3 cross(const Vec3& a, const Vec3& b)
{
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double dot3(const Vec3& a, const Vec3& b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// The six neighbours and the fan triangles [p, N_a, N_b] (orientation of
// the owned triangles).
const int kNeighbour[6][2] = {{0, -1}, {1, -1}, {1, 0}, {0, 1}, {-1, 1}, {-1, 0}};
const int kFan[6][2] = {{2, 1}, {1, 0}, {0, 5}, {5, 4}, {4, 3}, {3, 2}};

double fix_energy(double cx, double cy, double w)
{
    const double u = 1.0 - w * w * (cx * cx + cy * cy);
    return u > 0.0 ? 0.5 / u : kInf;
}

struct Edges {
    Vec2 e;
    Vec3 f;
};

// Edge from node (i, j) to its neighbour k, with p's offset moved to cp.
Edges edge(const CorrectionGrid& g, const std::vector<double>& c, int i, int j, int k, double cpx, double cpy)
{
    const int dx = kNeighbour[k][0], dy = kNeighbour[k][1];
    const int q = wrap(j + dy, g.ny) * g.nx + wrap(i + dx, g.nx);
    const int p = j * g.nx + i;
    return {{dx + c[2 * q] - cpx, dy + c[2 * q + 1] - cpy}, {double(dx), double(dy), g.z[q] - g.z[p]}};
}

double fan_energy_at(const CorrectionGrid& g, const std::vector<double>& c, int i, int j, double cpx,
                     double cpy)
{
    double e = 0.0;
    for (const auto& t : kFan) {
        const Edges a = edge(g, c, i, j, t[0], cpx, cpy), b = edge(g, c, i, j, t[1], cpx, cpy);
        e += triangle_energy(a.e, b.e, a.f, b.f, g.theta);
    }
    if (!g.fix.empty())
        e += fix_energy(cpx, cpy, g.fix[j * g.nx + i]);
    return e;
}

bool movable(const CorrectionGrid& g, int i, int j)
{
    return (g.periodic_x || (i > 0 && i < g.nx - 1)) && (g.periodic_y || (j > 0 && j < g.ny - 1));
}

void update_node(const CorrectionGrid& g, std::vector<double>& c, int i, int j)
{
    const int p = j * g.nx + i;
    const Vec2 grad = fan_gradient(g, c, i, j);
    const double gn = std::hypot(grad[0], grad[1]);
    if (!(gn > 0.0) || !std::isfinite(gn))
        return;
    const double dx = -grad[0] / gn, dy = -grad[1] / gn;
    const double cx = c[2 * p], cy = c[2 * p + 1];
    // Bracket: the first flip of a fan triangle (texture area is linear in
    // the step), the fixation barrier, or 2 texels.
    double tmax = 2.0;
    for (const auto& t : kFan) {
        const Edges a = edge(g, c, i, j, t[0], cx, cy), b = edge(g, c, i, j, t[1], cx, cy);
        auto area = [&](double s) {
            const Vec2 e1{a.e[0] - s * dx, a.e[1] - s * dy}, e2{b.e[0] - s * dx, b.e[1] - s * dy};
            return 0.5 * (e1[1] * e2[0] - e1[0] * e2[1]);
        };
        const double a0 = area(0.0), a1 = area(1.0) - a0;
        if (a1 < 0.0)
            tmax = std::min(tmax, -a0 / a1);
    }
    if (!g.fix.empty() && g.fix[p] > 0.0) {
        const double w = g.fix[p], cd = cx * dx + cy * dy;
        tmax = std::min(tmax, -cd + std::sqrt(std::max(0.0, cd * cd - (cx * cx + cy * cy) + 1.0 / (w * w))));
    }
    if (!(tmax > 0.0))
        return;
    auto energy = [&](double s) { return fan_energy_at(g, c, i, j, cx + s * dx, cy + s * dy); };
    double lo = 0.0, hi = tmax, s = 0.0, es = 0.0;
    const double e0 = energy(0.0);
    const double r = (3.0 - std::sqrt(5.0)) / 2.0;
    if (g.search == CorrectionGrid::Search::Brent) {
        // Brent's minimiser from t = 0 (Numerical Recipes' brent(), the
        // bracket [0, tmax]); non-finite energies count as higher.
        double x = 0.0, w = 0.0, v = 0.0, fx = e0, fw = e0, fv = e0, d = 0.0, e = 0.0;
        for (int it = 0; it < 5; ++it) {
            const double xm = 0.5 * (lo + hi), tol1 = 0.01 * std::abs(x) + 1e-6 * tmax, tol2 = 2.0 * tol1;
            if (std::abs(x - xm) <= tol2 - 0.5 * (hi - lo))
                break;
            bool golden = true;
            if (std::abs(e) > tol1) {
                const double rr = (x - w) * (fx - fv);
                double q = (x - v) * (fx - fw), p = (x - v) * q - (x - w) * rr;
                q = 2.0 * (q - rr);
                if (q > 0.0)
                    p = -p;
                q = std::abs(q);
                if (std::isfinite(p) && std::isfinite(q) && std::abs(p) < std::abs(0.5 * q * e) &&
                    p > q * (lo - x) && p < q * (hi - x)) {
                    e = d;
                    d = p / q;
                    if (x + d - lo < tol2 || hi - (x + d) < tol2)
                        d = std::copysign(tol1, xm - x);
                    golden = false;
                }
            }
            if (golden) {
                e = x >= xm ? lo - x : hi - x;
                d = r * e;
            }
            const double u = std::abs(d) >= tol1 ? x + d : x + std::copysign(tol1, d);
            const double fu = energy(u);
            if (fu <= fx) {
                (u >= x ? lo : hi) = x;
                v = w, fv = fw, w = x, fw = fx, x = u, fx = fu;
            } else {
                (u < x ? lo : hi) = u;
                if (!(fu > fw) || w == x)
                    v = w, fv = fw, w = u, fw = fu;
                else if (!(fu > fv) || v == x || v == w)
                    v = u, fv = fu;
            }
        }
        s = x;
        es = fx;
    } else if (g.search == CorrectionGrid::Search::Golden) {
        // Golden section: keep the interior point that survives, add one.
        double x1 = r * hi, x2 = hi - r * hi, e1 = energy(x1), e2 = energy(x2);
        for (int step = 0; step < 10 && hi - lo > 1e-6 * tmax; ++step) {
            if (!std::isfinite(e1)) {
                hi = x1;
                x1 = lo + r * (hi - lo);
                x2 = hi - r * (hi - lo);
                e1 = energy(x1);
                e2 = energy(x2);
            } else if (std::isfinite(e2) && std::abs(e1 - e2) <= 1e-7 * (e1 + e2)) {
                break;
            } else if (!std::isfinite(e2) || e1 < e2) {
                hi = x2;
                x2 = x1;
                e2 = e1;
                x1 = lo + r * (hi - lo);
                e1 = energy(x1);
            } else {
                lo = x1;
                x1 = x2;
                e1 = e2;
                x2 = hi - r * (hi - lo);
                e2 = energy(x2);
            }
        }
        s = e1 <= e2 ? x1 : x2;
        es = e1 <= e2 ? e1 : e2;
    } else {
        for (int step = 0; step < 31 && hi - lo > 1e-6 * tmax; ++step) {
            const double m1 = lo + (hi - lo) / 3.0, m2 = hi - (hi - lo) / 3.0;
            if (energy(m1) < energy(m2))
                hi = m2;
            else
                lo = m1;
        }
        s = 0.5 * (lo + hi);
        es = energy(s);
    }
    // A move must lower the fan energy by more than 1e-6 of it (the kernel's
    // rounding guard, CORRECT_GAIN).
    const double floor_e = e0 - 1e-6 * e0;
    if (g.relax != 1.0 && g.relax * s < tmax && energy(g.relax * s) < floor_e)
        s *= g.relax;
    else if (!(es < floor_e))
        return;
    c[2 * p] = cx + s * dx;
    c[2 * p + 1] = cy + s * dy;
}

}  // namespace

double triangle_energy(const Vec2& e1, const Vec2& e2, const Vec3& f1, const Vec3& f2, double theta)
{
    const double auv = 0.5 * (e1[1] * e2[0] - e1[0] * e2[1]);
    if (!(auv > 0.0))
        return kInf;
    const Vec3 n = cross(f1, f2);
    const double a3 = 0.5 * std::sqrt(dot3(n, n));
    // |J|_F^2 = tr(M (E^T E)^-1), M the Gram matrix of f1, f2.
    const double a = e1[0] * e1[0] + e1[1] * e1[1], b = e1[0] * e2[0] + e1[1] * e2[1],
                 cc = e2[0] * e2[0] + e2[1] * e2[1];
    const double frob = (dot3(f1, f1) * cc - 2.0 * dot3(f1, f2) * b + dot3(f2, f2) * a) / (4.0 * auv * auv);
    const double ratio = a3 / auv;  // s1 s2
    return frob * auv / a3 * std::pow(ratio + 1.0 / ratio, theta);
}

std::array<double, 2> triangle_singular_values(const Vec2& e1, const Vec2& e2, const Vec3& f1, const Vec3& f2)
{
    // E^-1 of the 2x2 [e1 e2]; J = [f1 f2] E^-1 (3x2).
    const double det = e1[0] * e2[1] - e2[0] * e1[1];
    const double inv[2][2] = {{e2[1] / det, -e2[0] / det}, {-e1[1] / det, e1[0] / det}};
    double J[3][2];
    for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 2; ++k)
            J[r][k] = f1[r] * inv[0][k] + f2[r] * inv[1][k];
    double m[2][2] = {{0, 0}, {0, 0}};
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            for (int r = 0; r < 3; ++r)
                m[a][b] += J[r][a] * J[r][b];
    const double tr = m[0][0] + m[1][1], dt = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    const double disc = std::sqrt(std::max(0.0, tr * tr / 4.0 - dt));
    return {std::sqrt(tr / 2.0 + disc), std::sqrt(std::max(0.0, tr / 2.0 - disc))};
}

double total_energy(const CorrectionGrid& g, const std::vector<double>& c)
{
    double e = 0.0;
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i) {
            if ((g.periodic_x || i + 1 < g.nx) && (g.periodic_y || j >= 1)) {
                // Owned triangles = fan triangles 0 and 1 of p.
                for (int t = 0; t < 2; ++t) {
                    const Edges a =
                        edge(g, c, i, j, kFan[t][0], c[2 * (j * g.nx + i)], c[2 * (j * g.nx + i) + 1]);
                    const Edges b =
                        edge(g, c, i, j, kFan[t][1], c[2 * (j * g.nx + i)], c[2 * (j * g.nx + i) + 1]);
                    e += triangle_energy(a.e, b.e, a.f, b.f, g.theta);
                }
            }
            if (!g.fix.empty())
                e += fix_energy(c[2 * (j * g.nx + i)], c[2 * (j * g.nx + i) + 1], g.fix[j * g.nx + i]);
        }
    return e;
}

double fan_energy(const CorrectionGrid& g, const std::vector<double>& c, int i, int j)
{
    const int p = j * g.nx + i;
    return fan_energy_at(g, c, i, j, c[2 * p], c[2 * p + 1]);
}

Vec2 fan_gradient(const CorrectionGrid& g, const std::vector<double>& c, int i, int j)
{
    // dE/dp = -(dE/de1 + dE/de2) per fan triangle, with
    // E = Q/(4 A3 Auv) k^theta, k = A3/Auv + Auv/A3.
    const int p = j * g.nx + i;
    const double cx = c[2 * p], cy = c[2 * p + 1];
    Vec2 grad{0.0, 0.0};
    for (const auto& t : kFan) {
        const Edges ea = edge(g, c, i, j, t[0], cx, cy), eb = edge(g, c, i, j, t[1], cx, cy);
        const Vec2 &e1 = ea.e, &e2 = eb.e;
        const Vec3 n = cross(ea.f, eb.f);
        const double a3 = 0.5 * std::sqrt(dot3(n, n));
        const double m11 = dot3(ea.f, ea.f), m12 = dot3(ea.f, eb.f), m22 = dot3(eb.f, eb.f);
        const double auv = 0.5 * (e1[1] * e2[0] - e1[0] * e2[1]);
        const double q = m11 * (e2[0] * e2[0] + e2[1] * e2[1]) - 2.0 * m12 * (e1[0] * e2[0] + e1[1] * e2[1]) +
                         m22 * (e1[0] * e1[0] + e1[1] * e1[1]);
        const double k = a3 / auv + auv / a3;
        const double G = std::pow(k, g.theta), F = q / (4.0 * a3 * auv);
        const double dEdQ = G / (4.0 * a3 * auv);
        const double dEdA =
            -F * G / auv + F * g.theta * std::pow(k, g.theta - 1.0) * (1.0 / a3 - a3 / (auv * auv));
        for (int d = 0; d < 2; ++d) {
            const double dQ = 2.0 * (m22 - m12) * e1[d] + 2.0 * (m11 - m12) * e2[d];
            const double dA = d == 0 ? 0.5 * (e1[1] - e2[1]) : 0.5 * (e2[0] - e1[0]);
            grad[d] -= dEdQ * dQ + dEdA * dA;
        }
    }
    if (!g.fix.empty()) {
        const double w = g.fix[p], u = 1.0 - w * w * (cx * cx + cy * cy);
        grad[0] += w * w * cx / (u * u);
        grad[1] += w * w * cy / (u * u);
    }
    return grad;
}

void iterate(const CorrectionGrid& g, std::vector<double>& c)
{
    // Per axis: even, odd, and the last node of an odd periodic axis.
    auto classes = [&](int n, bool periodic) { return periodic && n % 2 == 1 && n > 1 ? 3 : 2; };
    auto in_class = [&](int v, int n, bool periodic, int cls) {
        const bool last_odd = periodic && n % 2 == 1 && v == n - 1;
        return cls == 2 ? last_odd : (!last_odd && v % 2 == cls);
    };
    for (int cy = 0; cy < classes(g.ny, g.periodic_y); ++cy)
        for (int cx = 0; cx < classes(g.nx, g.periodic_x); ++cx)
            for (int j = 0; j < g.ny; ++j)
                for (int i = 0; i < g.nx; ++i)
                    if (in_class(i, g.nx, g.periodic_x, cx) && in_class(j, g.ny, g.periodic_y, cy) &&
                        movable(g, i, j))
                        update_node(g, c, i, j);
}

namespace {

bool hat_axis_fits(int n, bool periodic, int B)
{
    return periodic ? n % (2 * B) == 0 && n >= 4 * B : n >= 2 * B + 1;
}

double hat_axis_weight(int x, int centre, int B, int n, bool periodic)
{
    int d = std::abs(x - centre);
    if (periodic)
        d = std::min(d, n - d);
    else if (x == 0 || x == n - 1)
        return 0.0;
    return d < B ? 1.0 - double(d) / B : 0.0;
}

// The owned triangles as (owner, corner a, corner b) node indices, in the
// orientation of total_energy's.
struct Triangle {
    int p, a, b;
};

std::vector<Triangle> owned_triangles(const CorrectionGrid& g)
{
    std::vector<Triangle> t;
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i)
            if ((g.periodic_x || i + 1 < g.nx) && (g.periodic_y || j >= 1)) {
                auto node = [&](int k) {
                    return wrap(j + kNeighbour[k][1], g.ny) * g.nx + wrap(i + kNeighbour[k][0], g.nx);
                };
                for (int f = 0; f < 2; ++f)
                    t.push_back({j * g.nx + i, node(kFan[f][0]), node(kFan[f][1])});
            }
    return t;
}

// The lattice step from node p to its neighbour q (texels, the nearer
// image across a wrap seam).
Vec2 lattice_edge(const CorrectionGrid& g, int p, int q)
{
    int dx = q % g.nx - p % g.nx, dy = q / g.nx - p / g.nx;
    dx = dx > 1 ? dx - g.nx : dx < -1 ? dx + g.nx : dx;
    dy = dy > 1 ? dy - g.ny : dy < -1 ? dy + g.ny : dy;
    return {double(dx), double(dy)};
}

// The texture edge from p to q with offsets c.
Vec2 texture_edge(const CorrectionGrid& g, const std::vector<double>& c, int p, int q)
{
    const Vec2 d = lattice_edge(g, p, q);
    return {d[0] + c[2 * q] - c[2 * p], d[1] + c[2 * q + 1] - c[2 * p + 1]};
}

double triangle_energy_of(const CorrectionGrid& g, const std::vector<double>& c, const Triangle& t)
{
    const Vec2 da = lattice_edge(g, t.p, t.a), db = lattice_edge(g, t.p, t.b);
    const Vec3 fa{da[0], da[1], g.z[t.a] - g.z[t.p]}, fb{db[0], db[1], g.z[t.b] - g.z[t.p]};
    return triangle_energy(texture_edge(g, c, t.p, t.a), texture_edge(g, c, t.p, t.b), fa, fb, g.theta);
}

// The kernels' search for a step t in (0, limit) along a descent direction
// (both the hats and the global steps): up to three tries from `probe`,
// each 8x nearer, of the probe itself and of the minimum of the parabola
// through E(0) = e0 with slope -descent and E(probe), kept under 0.95
// limit; stops at the first try that lowers the energy. The step, or 0
// where no try lowered it by 1e-6 of e0.
template <class Energy>
double probe_search(const Energy& energy, double e0, double descent, double probe, double limit)
{
    double best = e0, best_t = 0.0;
    for (int tries = 0; tries < 3 && best_t == 0.0; ++tries, probe *= 0.125) {
        const double ep = energy(probe);
        if (!std::isfinite(ep))
            continue;
        if (ep < best) {
            best = ep;
            best_t = probe;
        }
        const double curvature = (ep - e0 + descent * probe) / (probe * probe);
        if (!(curvature > 0.0))
            continue;
        const double t = std::min(descent / (2.0 * curvature), 0.95 * limit);
        if (!(t > 0.0) || t == probe)
            continue;
        const double et = energy(t);
        if (std::isfinite(et) && et < best) {
            best = et;
            best_t = t;
        }
    }
    return best_t > 0.0 && best < e0 - 1e-6 * e0 ? best_t : 0.0;
}
}  // namespace

int hat_sweep(const CorrectionGrid& g, std::vector<double>& c)
{
    const std::vector<Triangle> all = owned_triangles(g);
    int scales = 0;
    for (int B = 2; hat_axis_fits(g.nx, g.periodic_x, B) && hat_axis_fits(g.ny, g.periodic_y, B); B *= 2) {
        ++scales;
        const int hx = g.periodic_x ? g.nx / B : (g.nx - 1) / B + 1;
        const int hy = g.periodic_y ? g.ny / B : (g.ny - 1) / B + 1;
        for (int cy = 0; cy < 2; ++cy)
            for (int cx = 0; cx < 2; ++cx)
                for (int hj = cy; hj < hy; hj += 2)
                    for (int hi = cx; hi < hx; hi += 2) {
                        std::vector<double> w(std::size_t(g.nx) * g.ny);
                        for (int j = 0; j < g.ny; ++j)
                            for (int i = 0; i < g.nx; ++i)
                                w[std::size_t(j) * g.nx + i] =
                                    hat_axis_weight(i, hi * B, B, g.nx, g.periodic_x) *
                                    hat_axis_weight(j, hj * B, B, g.ny, g.periodic_y);
                        std::vector<Triangle> touched;
                        for (const Triangle& t : all)
                            if (w[t.a] != w[t.p] || w[t.b] != w[t.p])
                                touched.push_back(t);
                        Vec2 grad{0.0, 0.0};
                        for (int j = 0; j < g.ny; ++j)
                            for (int i = 0; i < g.nx; ++i)
                                if (w[std::size_t(j) * g.nx + i] != 0.0) {
                                    const Vec2 gn = fan_gradient(g, c, i, j);
                                    grad[0] += w[std::size_t(j) * g.nx + i] * gn[0];
                                    grad[1] += w[std::size_t(j) * g.nx + i] * gn[1];
                                }
                        const double gn = std::hypot(grad[0], grad[1]);
                        auto moved = [&](double t) {
                            std::vector<double> m = c;
                            for (std::size_t n = 0; n < w.size(); ++n) {
                                m[2 * n] -= t * w[n] * grad[0] / gn;
                                m[2 * n + 1] -= t * w[n] * grad[1] / gn;
                            }
                            return m;
                        };
                        auto energy = [&](double t) {
                            const std::vector<double> m = moved(t);
                            double e = 0.0;
                            for (const Triangle& tr : touched)
                                e += triangle_energy_of(g, m, tr);
                            return e;
                        };
                        const double e0 = energy(0.0);
                        if (!std::isfinite(e0) || !(gn > 0.0) || !std::isfinite(gn))
                            continue;
                        double tmax = 2.0 * B;
                        const std::vector<double> m1 = moved(1.0);
                        for (const Triangle& tr : touched) {
                            auto area = [&](const std::vector<double>& m) {
                                const Vec2 ea = texture_edge(g, m, tr.p, tr.a),
                                           eb = texture_edge(g, m, tr.p, tr.b);
                                return 0.5 * (ea[1] * eb[0] - ea[0] * eb[1]);
                            };
                            const double a0 = area(c), a1 = area(m1) - a0;
                            if (a1 < 0.0)
                                tmax = std::min(tmax, -a0 / a1);
                        }
                        if (!(tmax > 0.0))
                            continue;
                        if (const double t = probe_search(energy, e0, gn, 0.5 * tmax, tmax); t > 0.0)
                            c = moved(t);
                    }
    }
    return scales;
}

namespace {

// A field of 2-vectors on an nx x ny lattice.
struct Lattice {
    int nx = 0, ny = 0;
    std::vector<double> v;  // 2 per node
};

bool lattice_pinned(int i, int j, int nx, int ny, bool px, bool py)
{
    return (!px && (i == 0 || i == nx - 1)) || (!py && (j == 0 || j == ny - 1));
}

// Full weighting onto every other node: weights 1, 1/2 per axis off centre.
Lattice restrict_lattice(const Lattice& f, bool px, bool py)
{
    Lattice c;
    c.nx = px ? f.nx / 2 : (f.nx - 1) / 2 + 1;
    c.ny = py ? f.ny / 2 : (f.ny - 1) / 2 + 1;
    c.v.assign(2 * std::size_t(c.nx) * c.ny, 0.0);
    for (int J = 0; J < c.ny; ++J)
        for (int I = 0; I < c.nx; ++I) {
            if (lattice_pinned(I, J, c.nx, c.ny, px, py))
                continue;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    int x = 2 * I + dx, y = 2 * J + dy;
                    if (px)
                        x = wrap(x, f.nx);
                    if (py)
                        y = wrap(y, f.ny);
                    if (x < 0 || x >= f.nx || y < 0 || y >= f.ny)
                        continue;
                    const double w = (dx ? 0.5 : 1.0) * (dy ? 0.5 : 1.0);
                    for (int d = 0; d < 2; ++d)
                        c.v[2 * (std::size_t(J) * c.nx + I) + d] +=
                            w * f.v[2 * (std::size_t(y) * f.nx + x) + d];
                }
        }
    return c;
}

// f += c interpolated bilinearly (the transpose of restrict_lattice);
// pinned nodes of f zero.
void prolong_lattice(const Lattice& c, Lattice& f, bool px, bool py)
{
    for (int j = 0; j < f.ny; ++j)
        for (int i = 0; i < f.nx; ++i) {
            double* out = &f.v[2 * (std::size_t(j) * f.nx + i)];
            if (lattice_pinned(i, j, f.nx, f.ny, px, py)) {
                out[0] = out[1] = 0.0;
                continue;
            }
            for (int J = j / 2; J <= (j + 1) / 2; ++J)
                for (int I = i / 2; I <= (i + 1) / 2; ++I) {
                    const int x = px ? wrap(I, c.nx) : I, y = py ? wrap(J, c.ny) : J;
                    if (x >= c.nx || y >= c.ny)
                        continue;
                    const double w = (i & 1 ? 0.5 : 1.0) * (j & 1 ? 0.5 : 1.0);
                    for (int d = 0; d < 2; ++d)
                        out[d] += w * c.v[2 * (std::size_t(y) * c.nx + x) + d];
                }
        }
}

bool lattice_halves(int n, bool periodic)
{
    return periodic ? n % 2 == 0 && n / 2 >= 4 : (n - 1) / 2 + 1 >= 3;
}

// Every movable node's energy gradient (pinned nodes 0).
std::vector<double> node_gradients(const CorrectionGrid& g, const std::vector<double>& c)
{
    std::vector<double> G(2 * std::size_t(g.nx) * g.ny, 0.0);
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i)
            if (movable(g, i, j)) {
                const Vec2 d = fan_gradient(g, c, i, j);
                G[2 * (std::size_t(j) * g.nx + i)] = d[0];
                G[2 * (std::size_t(j) * g.nx + i) + 1] = d[1];
            }
    return G;
}

double dot(const std::vector<double>& u, const std::vector<double>& v)
{
    double s = 0.0;
    for (std::size_t k = 0; k < u.size(); ++k)
        s += u[k] * v[k];
    return s;
}

}  // namespace

std::vector<double> multilevel_sum(const CorrectionGrid& g, std::vector<double> v)
{
    std::vector<Lattice> lat{Lattice{g.nx, g.ny, std::move(v)}};
    while (lattice_halves(lat.back().nx, g.periodic_x) && lattice_halves(lat.back().ny, g.periodic_y))
        lat.push_back(restrict_lattice(lat.back(), g.periodic_x, g.periodic_y));
    for (std::size_t l = lat.size() - 1; l > 0; --l)
        prolong_lattice(lat[l], lat[l - 1], g.periodic_x, g.periodic_y);
    return lat[0].v;
}

std::vector<double> multilevel_gradient(const CorrectionGrid& g, const std::vector<double>& c)
{
    return multilevel_sum(g, node_gradients(g, c));
}

bool global_step(const CorrectionGrid& g, std::vector<double>& c, GlobalStepMemory* memory)
{
    const std::vector<double> G = node_gradients(g, c);
    std::vector<double> S;
    if (memory && !memory->x.empty()) {
        std::vector<double> s(c.size()), y(c.size());
        for (std::size_t k = 0; k < c.size(); ++k) {
            s[k] = c[k] - memory->x[k];
            y[k] = G[k] - memory->G[k];
        }
        const double sy = dot(s, y);
        if (sy > 1e-8 * std::sqrt(dot(s, s) * dot(y, y))) {
            const double a = dot(s, G) / sy;
            std::vector<double> q(G.size());
            for (std::size_t k = 0; k < q.size(); ++k)
                q[k] = G[k] - a * y[k];
            S = multilevel_sum(g, q);
            const double b = dot(y, S) / sy;
            for (std::size_t k = 0; k < S.size(); ++k)
                S[k] += (a - b) * s[k];
            if (!(dot(G, S) > 0.0))
                S.clear();
        }
    }
    if (memory) {
        memory->used_pair = !S.empty();
        memory->x = c;
        memory->G = G;
    }
    if (S.empty())
        S = multilevel_sum(g, G);
    double slope = 0.0, largest = 0.0;
    for (std::size_t k = 0; k < S.size(); k += 2) {
        slope -= G[k] * S[k] + G[k + 1] * S[k + 1];
        largest = std::max(largest, std::hypot(S[k], S[k + 1]));
    }
    // The first flip moving every node by -t S: per owned triangle, 2 Auv(t)
    // is a quadratic in t.
    double flip = kInf;
    for (const Triangle& t : owned_triangles(g)) {
        const Vec2 ea = texture_edge(g, c, t.p, t.a), eb = texture_edge(g, c, t.p, t.b);
        const Vec2 da{S[2 * t.p] - S[2 * t.a], S[2 * t.p + 1] - S[2 * t.a + 1]};
        const Vec2 db{S[2 * t.p] - S[2 * t.b], S[2 * t.p + 1] - S[2 * t.b + 1]};
        const double a0 = ea[1] * eb[0] - ea[0] * eb[1];
        const double a1 = da[1] * eb[0] + ea[1] * db[0] - da[0] * eb[1] - ea[0] * db[1];
        const double a2 = da[1] * db[0] - da[0] * db[1];
        if (a2 == 0.0) {
            if (a1 < 0.0)
                flip = std::min(flip, -a0 / a1);
            continue;
        }
        const double disc = a1 * a1 - 4.0 * a2 * a0;
        if (disc < 0.0)
            continue;
        for (const double r : {(-a1 - std::sqrt(disc)) / (2.0 * a2), (-a1 + std::sqrt(disc)) / (2.0 * a2)})
            if (r > 0.0)
                flip = std::min(flip, r);
    }
    if (!(slope < 0.0) || !(largest > 0.0) || !(flip > 0.0))
        return false;
    const double E0 = total_energy(g, c);
    std::vector<double> moved(c.size());
    const auto energy_at = [&](double t) {
        for (std::size_t k = 0; k < c.size(); ++k)
            moved[k] = c[k] - t * S[k];
        return total_energy(g, moved);
    };
    const double best_t = probe_search(energy_at, E0, -slope, std::min(0.5 * flip, 1.0 / largest), flip);
    if (best_t == 0.0)
        return false;
    for (std::size_t k = 0; k < c.size(); ++k)
        c[k] -= best_t * S[k];
    return true;
}

}  // namespace relief::reference

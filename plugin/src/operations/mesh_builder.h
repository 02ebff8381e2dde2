// SPDX-License-Identifier: Apache-2.0
#pragma once
// The mesh builder of relief::displaced_mesh (mesh.cpp): vertices keyed by
// exact rational positions, patches tessellated at their levels and
// stitched along shared sides (the scheme is described in mesh.cpp).
// Included only by mesh.cpp.
#include <algorithm>
#include <new>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory_resource>
#include <numeric>
#include <unordered_map>
#include <vector>

#include "device/cancel.h"
#include "relief/check.h"

namespace relief::detail::mesh_building {

struct Rational {
    std::int64_t n = 0, d = 1;  // reduced, d > 0
};

inline Rational rational(std::int64_t n, std::int64_t d)
{
    const std::int64_t g = std::gcd(n < 0 ? -n : n, d);
    return g > 1 ? Rational{n / g, d / g} : Rational{n, d};
}

inline bool operator<(const Rational& a, const Rational& b)
{
    return a.n * b.d < b.n * a.d;
}
inline bool operator==(const Rational& a, const Rational& b)
{
    return a.n == b.n && a.d == b.d;
}

// a + (b - a) t for integers a, b and a fraction t.
inline Rational along(int a, int b, const Rational& t)
{
    return rational(std::int64_t(a) * t.d + std::int64_t(b - a) * t.n, t.d);
}

struct Key {
    Rational x, y;
    bool operator==(const Key& o) const { return x == o.x && y == o.y; }
};

struct KeyHash {
    std::size_t operator()(const Key& k) const
    {
        std::size_t s = std::hash<std::int64_t>()(k.x.n);
        for (std::int64_t v : {k.x.d, k.y.n, k.y.d})
            s = s * 1000003u ^ std::hash<std::int64_t>()(v);
        return s;
    }
};

enum Side { Top, Right, Bottom, Left };

class Builder {
public:
    Builder(const std::vector<float>& h, int w, int ht, const TessellationOptions& o)
        : h_(h), w_(w), ht_(ht), patch_(o.patch), scale_(o.scale), px_((w + o.patch - 1) / o.patch),
          py_((ht + o.patch - 1) / o.patch)
    {
    }

    int patches() const { return px_ * py_; }

    // Sets the levels and (re)builds the patches listed (all, the first
    // time); returns nothing, errors() has each patch's largest error.
    // Vertices are kept across calls: they are keyed by exact position, so
    // a rebuilt patch finds its neighbours' side vertices again.
    void build(const std::vector<int>& levels, const std::vector<int>& which)
    {
        host::stop_if_cancelled();
        levels_ = levels;
        tris_.resize(std::size_t(patches()));
        errors_.resize(std::size_t(patches()));
        // Room for every vertex the listed patches can add (a side shared
        // with a neighbour counted twice): grown by doubling, the index
        // rehashed and the arrays copied millions of entries at a time,
        // 0.2-0.4 s at 1024^2 in which a host heard nothing.
        // At most twice the memory check's own count (check_mesh_memory,
        // max(L, 1)^2 a patch), which a map of level-1 patches would pass.
        std::size_t room = 0, cap = 0;
        for (int p : which) {
            const std::size_t level = std::size_t(std::max(levels_[std::size_t(p)], 1));
            room += (level + 1) * (level + 1);
            cap += 2 * level * level;
        }
        if (pos_.empty())
            room += room / 4;  // (the patches raised later: growing would copy it all again)
        room = pos_.size() / 3 + std::min(room, cap);
        if (double(room) > double(index_.bucket_count()) * double(index_.max_load_factor()))
            index_.reserve(room);
        pos_.reserve(3 * room);
        nrm_.reserve(3 * room);
        uv_.reserve(2 * room);
        for (int p : which) {
            host::stop_if_cancelled();  // (a 1024^2 map of 16-texel patches: 1.4 ms a patch here)
            cur_ = &tris_[std::size_t(p)];
            cur_->clear();
            add_patch(p);
            errors_[std::size_t(p)] = patch_error(p);
        }
    }

    const std::vector<double>& errors() const { return errors_; }

    // The mesh: the patches' triangles in patch order, the vertices they
    // use numbered in order of first use (the same mesh whatever was rebuilt).
    Mesh finish() const
    {
        Mesh m;
        std::vector<std::uint32_t> number(pos_.size() / 3, UINT32_MAX);
        std::size_t corners = 0;
        for (const auto& list : tris_)
            corners += list.size();
        m.positions.reserve(pos_.size());
        m.normals.reserve(nrm_.size());
        m.texcoords.reserve(uv_.size());
        m.triangles.reserve(corners);
        for (const auto& list : tris_) {
            if ((&list - tris_.data()) % 64 == 0)
                host::stop_if_cancelled();
            for (std::uint32_t v : list) {
                if (number[v] == UINT32_MAX) {
                    number[v] = std::uint32_t(m.positions.size() / 3);
                    m.positions.insert(m.positions.end(), &pos_[3 * std::size_t(v)],
                                       &pos_[3 * std::size_t(v)] + 3);
                    m.normals.insert(m.normals.end(), &nrm_[3 * std::size_t(v)],
                                     &nrm_[3 * std::size_t(v)] + 3);
                    m.texcoords.insert(m.texcoords.end(), &uv_[2 * std::size_t(v)],
                                       &uv_[2 * std::size_t(v)] + 2);
                }
                m.triangles.push_back(number[v]);
            }
        }
        m.levels = levels_;
        m.errors = errors_;
        return m;
    }

private:
    struct Bounds {
        int x0, y0, x1, y1;
    };

    Bounds bounds(int p) const
    {
        const int x0 = (p % px_) * patch_, y0 = (p / px_) * patch_;
        return {x0, y0, std::min(x0 + patch_, w_), std::min(y0 + patch_, ht_)};
    }

    // The neighbour across `side`, or -1 at the image border.
    int neighbour(int p, Side side) const
    {
        const int x = p % px_, y = p / px_;
        switch (side) {
        case Top: return y > 0 ? p - px_ : -1;
        case Bottom: return y + 1 < py_ ? p + px_ : -1;
        case Left: return x > 0 ? p - 1 : -1;
        case Right: return x + 1 < px_ ? p + 1 : -1;
        }
        return -1;
    }

    // The points of a side as fractions in [0, 1] from its start (top-left
    // end): this patch's and its neighbour's, sorted, each once.
    std::vector<Rational> side_points(int p, Side side) const
    {
        std::vector<Rational> t;
        const int q = neighbour(p, side);
        for (int L : {levels_[std::size_t(p)], q >= 0 ? levels_[std::size_t(q)] : 0})
            for (int k = 0; k <= L && L > 0; ++k)
                t.push_back(rational(k, L));
        std::sort(t.begin(), t.end());
        t.erase(std::unique(t.begin(), t.end()), t.end());
        return t;
    }

    // The vertex at fraction t of a side.
    Key side_key(const Bounds& b, Side side, const Rational& t) const
    {
        switch (side) {
        case Top: return {along(b.x0, b.x1, t), rational(b.y0, 1)};
        case Bottom: return {along(b.x0, b.x1, t), rational(b.y1, 1)};
        case Left: return {rational(b.x0, 1), along(b.y0, b.y1, t)};
        case Right: return {rational(b.x1, 1), along(b.y0, b.y1, t)};
        }
        return {};
    }

    double height_at(double x, double y) const
    {
        const double tx = x - 0.5, ty = y - 0.5;
        const double fx0 = std::floor(tx), fy0 = std::floor(ty);
        const double fx = tx - fx0, fy = ty - fy0;
        auto at = [&](double i, double j) {
            const int ci = std::clamp(int(i), 0, w_ - 1), cj = std::clamp(int(j), 0, ht_ - 1);
            return double(h_[std::size_t(cj) * std::size_t(w_) + std::size_t(ci)]);
        };
        return scale_ * ((1 - fy) * ((1 - fx) * at(fx0, fy0) + fx * at(fx0 + 1, fy0)) +
                         fy * ((1 - fx) * at(fx0, fy0 + 1) + fx * at(fx0 + 1, fy0 + 1)));
    }

    std::uint32_t vertex(const Key& k)
    {
        const auto found = index_.find(k);
        if (found != index_.end())
            return found->second;
        const std::uint32_t i = std::uint32_t(pos_.size() / 3);
        if (i == UINT32_MAX)
            throw std::runtime_error("the mesh has more than 2^32 - 1 vertices; use a larger error or patch");
        index_.emplace(k, i);
        const double x = double(k.x.n) / double(k.x.d), y = double(k.y.n) / double(k.y.d);
        const double dzdx = height_at(x + 0.5, y) - height_at(x - 0.5, y);
        const double dzdy = height_at(x, y + 0.5) - height_at(x, y - 0.5);
        const double len = std::sqrt(dzdx * dzdx + dzdy * dzdy + 1.0);
        pos_.insert(pos_.end(), {float(x), float(y), float(height_at(x, y))});
        nrm_.insert(nrm_.end(), {float(-dzdx / len), float(-dzdy / len), float(1.0 / len)});
        uv_.insert(uv_.end(), {float(x / w_), float(1.0 - y / ht_)});
        return i;
    }

    // One triangle, wound counter-clockwise seen from +z.
    void triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c)
    {
        const float* P = pos_.data();
        const double cross = (double(P[3 * b]) - P[3 * a]) * (double(P[3 * c + 1]) - P[3 * a + 1]) -
                             (double(P[3 * b + 1]) - P[3 * a + 1]) * (double(P[3 * c]) - P[3 * a]);
        if (cross < 0)
            std::swap(b, c);
        cur_->insert(cur_->end(), {a, b, c});
    }

    void add_patch(int p)
    {
        const Bounds b = bounds(p);
        const int L = levels_[std::size_t(p)];
        std::vector<Rational> sides[4];
        bool split = false;
        for (Side s : {Top, Right, Bottom, Left}) {
            sides[s] = side_points(p, s);
            split |= int(sides[s].size()) != L + 1;
        }
        if (L == 1 && split) {
            // A fan around the centre over the border's points, clockwise
            // from the top-left corner.
            const std::uint32_t centre = vertex({rational(b.x0 + b.x1, 2), rational(b.y0 + b.y1, 2)});
            std::vector<std::uint32_t> ring;
            for (Side s : {Top, Right, Bottom, Left}) {
                std::vector<Rational> t = sides[s];
                if (s == Bottom || s == Left)
                    std::reverse(t.begin(), t.end());
                for (std::size_t i = 0; i + 1 < t.size(); ++i)  // the last is the next side's first
                    ring.push_back(vertex(side_key(b, s, t[i])));
            }
            for (std::size_t i = 0; i < ring.size(); ++i)
                triangle(centre, ring[i], ring[(i + 1) % ring.size()]);
            return;
        }
        auto grid = [&](int a, int c) {
            return Key{along(b.x0, b.x1, rational(a, L)), along(b.y0, b.y1, rational(c, L))};
        };
        struct Corner {
            int a, c;
        };
        for (int c = 0; c < L; ++c)
            for (int a = 0; a < L; ++a) {
                const Corner v00{a, c}, v10{a + 1, c}, v01{a, c + 1}, v11{a + 1, c + 1};
                const bool main = (2 * a < L) == (2 * c < L);
                const Corner tris[2][3] = {{v00, v10, main ? v11 : v01}, {main ? v00 : v10, v11, v01}};
                for (const auto& t : tris)
                    add_grid_triangle(b, L, sides, t[0].a, t[0].c, t[1].a, t[1].c, t[2].a, t[2].c, grid);
            }
    }

    // A grid triangle; an edge on the patch border with extra points
    // (from a finer neighbour) becomes a fan from the opposite vertex.
    template <class Grid>
    void add_grid_triangle(const Bounds& b, int L, const std::vector<Rational>* sides, int a0, int c0, int a1,
                           int c1, int a2, int c2, Grid grid)
    {
        const int A[3] = {a0, a1, a2}, C[3] = {c0, c1, c2};
        for (int e = 0; e < 3; ++e) {
            const int i = e, j = (e + 1) % 3, k = (e + 2) % 3;
            Side side;
            if (C[i] == 0 && C[j] == 0)
                side = Top;
            else if (C[i] == L && C[j] == L)
                side = Bottom;
            else if (A[i] == 0 && A[j] == 0)
                side = Left;
            else if (A[i] == L && A[j] == L)
                side = Right;
            else
                continue;
            const bool horizontal = side == Top || side == Bottom;
            const Rational ti = rational(horizontal ? A[i] : C[i], L),
                           tj = rational(horizontal ? A[j] : C[j], L);
            std::vector<Rational> chain;
            for (const Rational& t : sides[side])
                if ((ti < t && t < tj) || (tj < t && t < ti))
                    chain.push_back(t);
            if (chain.empty())
                break;
            if (tj < ti)
                std::reverse(chain.begin(), chain.end());
            const std::uint32_t apex = vertex(grid(A[k], C[k]));
            std::uint32_t prev = vertex(grid(A[i], C[i]));
            for (const Rational& t : chain) {
                const std::uint32_t v = vertex(side_key(b, side, t));
                triangle(apex, prev, v);
                prev = v;
            }
            triangle(apex, prev, vertex(grid(A[j], C[j])));
            return;
        }
        triangle(vertex(grid(A[0], C[0])), vertex(grid(A[1], C[1])), vertex(grid(A[2], C[2])));
    }

    // The largest |surface - S h| over the texel centres of patch p, whose
    // every centre must be covered by its triangles.
    double patch_error(int p) const
    {
        const Bounds b = bounds(p);
        const int pw = b.x1 - b.x0;
        std::vector<double> err(std::size_t(pw) * std::size_t(b.y1 - b.y0), -1.0);
        const float* P = pos_.data();
        const std::vector<std::uint32_t>& tris = tris_[std::size_t(p)];
        for (std::size_t t = 0; t < tris.size(); t += 3) {
            double x[3], y[3], z[3];
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t v = tris[t + std::size_t(k)];
                x[k] = P[3 * v];
                y[k] = P[3 * v + 1];
                z[k] = P[3 * v + 2];
            }
            const double area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
            if (area <= 0.0)
                continue;
            const int i0 = std::max(b.x0, int(std::ceil(std::min({x[0], x[1], x[2]}) - 0.5)));
            const int i1 = std::min(b.x1 - 1, int(std::floor(std::max({x[0], x[1], x[2]}) - 0.5)));
            const int j0 = std::max(b.y0, int(std::ceil(std::min({y[0], y[1], y[2]}) - 0.5)));
            const int j1 = std::min(b.y1 - 1, int(std::floor(std::max({y[0], y[1], y[2]}) - 0.5)));
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) {
                    const double cx = i + 0.5, cy = j + 0.5;
                    const double l1 = ((x[2] - x[1]) * (cy - y[1]) - (y[2] - y[1]) * (cx - x[1])) / area;
                    const double l2 = ((x[0] - x[2]) * (cy - y[2]) - (y[0] - y[2]) * (cx - x[2])) / area;
                    const double l3 = 1.0 - l1 - l2;
                    if (l1 < -1e-9 || l2 < -1e-9 || l3 < -1e-9)
                        continue;
                    const double s = l1 * z[0] + l2 * z[1] + l3 * z[2];
                    const double e =
                        std::abs(s - scale_ * double(h_[std::size_t(j) * std::size_t(w_) + std::size_t(i)]));
                    double& slot = err[std::size_t(j - b.y0) * std::size_t(pw) + std::size_t(i - b.x0)];
                    slot = std::max(slot, e);
                }
        }
        double worst = 0.0;
        for (double e : err) {
            if (e < 0.0)
                throw std::logic_error("mesh: a texel centre of patch " + std::to_string(p) +
                                       " is not covered (a bug in the stitching)");
            worst = std::max(worst, e);
        }
        return worst;
    }

    const std::vector<float>& h_;
    const int w_, ht_, patch_;
    const double scale_;
    const int px_, py_;
    std::vector<int> levels_;
    std::vector<std::vector<std::uint32_t>> tris_;  // per patch, 3 per triangle
    std::vector<std::uint32_t>* cur_ = nullptr;     // the patch being built
    std::vector<double> errors_;                    // per patch
    std::vector<float> pos_, nrm_, uv_;             // every vertex made so far
    // The map's nodes come from one pool, freed with it in a few blocks:
    // freed one by one, a 1024^2 map's millions had taken 0.55 s, which a
    // cancel waited for. The map itself lives in the pool too and is never
    // destroyed (its keys and values need no destructor): its destructor
    // would still walk the millions of nodes, 0.15 s more.
    using Index = std::pmr::unordered_map<Key, std::uint32_t, KeyHash>;
    std::pmr::monotonic_buffer_resource pool_;
    Index& index_ = *new (pool_.allocate(sizeof(Index), alignof(Index))) Index(&pool_);
};

}  // namespace relief::detail::mesh_building

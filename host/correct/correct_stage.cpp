// SPDX-License-Identifier: Apache-2.0
// Distortion correction on the device: the coarse-to-fine driver around
// kernels/correct*.cl (per-level iterations of four or more phases, energy
// reductions, tile skipping) and the before/after statistics.
#include "correct/correct_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <future>
#include <limits>
#include <system_error>

#include "correct/correct_grid.h"
#include "correct/level_solver.h"
#include "device/cancel.h"
#include "errors.h"
#include "device/opencl_context.h"

namespace relief::host {

int CorrectReport::total_iterations() const
{
    int n = 0;
    for (const auto& l : levels)
        n += l.iterations;
    return n;
}

namespace {

void validate(const CorrectParams& p, int w, int h)
{
    if (w < 1 || h < 1)
        throw Error("distortion correction needs a non-empty height map");
    check_index_range(w, h, "correct");
    // The ranges are relief::validate()'s; these are what the solver relies on.
    expects(p.scale > 0.0 && std::isfinite(p.scale) && p.theta >= 0.0 && p.tolerance > 0.0 &&
                p.tolerance < 1.0 && p.iterations >= 0 && p.max_iterations >= 1 && p.levels >= 0 &&
                p.threshold >= 0.0 && p.relax >= 1.0 && p.relax < 2.0,
            "CorrectParams within relief::validate()'s ranges");
}

// A float's bits as an unsigned key in the float order (negatives reversed).
std::uint32_t order_key(float x)
{
    std::uint32_t u;
    std::memcpy(&u, &x, sizeof u);
    return u & 0x80000000u ? ~u : u | 0x80000000u;
}

// Mean, 95th percentile (the k-th smallest, exact) and largest. The
// percentile's value is found by its key's top 16 bits first, counted in
// one pass with the sum and the largest, then selected among the values
// that share them: std::nth_element over every triangle cost 12 ms at
// 1024^2, twice a run.
DistortionStats summarise(const std::vector<float>& v)
{
    DistortionStats s;
    if (v.empty())
        return s;
    std::vector<std::uint32_t> count(1 << 16, 0);
    double sum = 0.0;
    float largest = v[0];
    for (float x : v) {
        sum += x;
        largest = std::max(largest, x);
        ++count[order_key(x) >> 16];
    }
    s.mean = sum / double(v.size());
    s.max = largest;
    std::size_t k = std::min(v.size() - 1, std::size_t(std::ceil(0.95 * double(v.size()))) - 1);
    std::uint32_t bucket = 0;
    while (k >= count[bucket])
        k -= count[bucket++];
    std::vector<float> same;
    same.reserve(count[bucket]);
    for (float x : v)
        if (order_key(x) >> 16 == bucket)
            same.push_back(x);
    std::nth_element(same.begin(), same.begin() + std::ptrdiff_t(k), same.end());
    s.p95 = same[k];
    return s;
}

// Both statistics at once, the area's on a second thread (each a pass
// over every triangle and a selection within one bucket).
void summarise_both(const std::vector<float>& aniso, const std::vector<float>& area, DistortionStats& a,
                    DistortionStats& b)
{
    std::future<DistortionStats> other;
    try {
        other = std::async(std::launch::async, [&] { return summarise(area); });
    } catch (const std::system_error&) {  // no thread to be had: in turn
    }
    a = summarise(aniso);
    b = other.valid() ? other.get() : summarise(area);
}

struct LevelInput {
    NodeGrid grid;
    std::vector<float> z, fix;  // per node: height in texels, fixation weight
};

LevelInput level_input(const std::vector<float>& texel_heights, const std::vector<float>* fix, int w, int h,
                       int finest_w, const CorrectParams& p)
{
    LevelInput in;
    in.grid = NodeGrid(w, h, p.corner_nodes, p.periodic);
    in.z = node_values(texel_heights, in.grid);
    const float to_texels = float(p.scale * w);
    for (float& v : in.z)
        v *= to_texels;
    if (fix) {
        in.fix = node_values(*fix, in.grid);
        // The same limit in texture units at every level: 1/w fine texels.
        const float k = float(double(finest_w) / w);
        for (float& v : in.fix)
            v *= k;
    }
    return in;
}

// The caller's heights and fixation weights (none: empty), and the finest
// level's input made of them.
struct FinestInput {
    std::vector<float> texels, fix;
    LevelInput level;
};

FinestInput finest_input(const float* heights, int w, int h, const CorrectParams& p)
{
    const std::size_t n = std::size_t(w) * h;
    FinestInput in;
    in.texels.assign(heights, heights + n);
    if (p.fix_weights)
        in.fix.assign(p.fix_weights, p.fix_weights + n);
    in.level = level_input(in.texels, p.fix_weights ? &in.fix : nullptr, w, h, w, p);
    return in;
}

void to_texels(std::vector<float>& c, const NodeGrid& g, bool forward)
{
    for (std::size_t i = 0; i < c.size(); i += 2) {
        c[i] = forward ? c[i] * g.width : c[i] / g.width;
        c[i + 1] = forward ? c[i + 1] * g.height : c[i + 1] / g.height;
    }
}

// Rounds of unflipping moves before the polish's iterations (each a pass
// over the mesh).
constexpr int kUnflipRounds = 20;

// The corner solve minimises the energy of the corner mesh, but the output
// is the mean of each texel's four corners, and its mesh (the texel centres
// at their own heights) is what a bake shows. On a cliff the means can squeeze
// a centre triangle the corner energy does not see (a 1024^2 desert cliff:
// one triangle at 0.3% of its 3-D area carrying 97% of the delivered
// energy). A few iterations of the centre-node solver from the means (the
// same kernels, the same guarantees on the delivered mesh: its energy
// never rises, no triangle flips) remove it: the delivered energy fell
// 2.8x in one iteration there, 4% on an ordinary wall. Where the means
// flip triangles (a 4096^2 cliff's held 569), unflip_mesh() mends them
// first: a flipped triangle's infinite energy is nothing a node search
// can lower.
CorrectPolish polish_mesh(ComputeContext& ctx, const std::vector<float>& texels,
                          const std::vector<float>& fix, int w, int h, const CorrectParams& p,
                          std::vector<float>& offsets)
{
    const auto t0 = std::chrono::steady_clock::now();
    CorrectParams q = p;
    q.corner_nodes = false;
    q.iterations = p.polish;
    q.hats = CorrectParams::Hats::Off;
    q.global = CorrectParams::Global::Off;
    const LevelInput in = level_input(texels, fix.empty() ? nullptr : &fix, w, h, w, q);
    to_texels(offsets, in.grid, true);
    stop_if_cancelled();  // (host passes over the whole map, each tens of ms at 1024^2)
    CorrectPolish r;
    r.flipped = (long long)flipped_triangles(offsets, in.grid).size();
    if (r.flipped > 0) {
        r.repairs = unflip_mesh(offsets, in.grid, kUnflipRounds);
        r.flipped_left = (long long)flipped_triangles(offsets, in.grid).size();
    }
    stop_if_cancelled();
    LevelSolver s(ctx, in.grid, in.z, in.fix, q);
    s.upload(offsets);
    r.energy_start = s.energy();
    const CorrectLevel lv = s.solve({}, q.tolerance, r.energy_start, true, false);
    r.iterations = lv.iterations;
    r.energy_end = lv.energy_end;
    s.download(offsets);
    to_texels(offsets, in.grid, false);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

}  // namespace

CorrectPolish polish_delivered_mesh(ComputeContext& ctx, const std::vector<float>& heights,
                                    const std::vector<float>& fix_weights, int w, int h,
                                    const CorrectParams& p, std::vector<float>& offsets)
{
    validate(p, w, h);
    const std::size_t n = std::size_t(w) * h;
    expects(heights.size() == n && offsets.size() == 2 * n &&
                (fix_weights.empty() || fix_weights.size() == n),
            "polish_delivered_mesh: a height and an offset per texel");
    std::lock_guard<std::mutex> lock(ctx.impl().mutex);
    try {
        return polish_mesh(ctx, heights, fix_weights, w, h, p, offsets);
    } catch (const cl::Error& e) {
        throw opencl_error("correction", e);
    }
}

void correct_distortion(ComputeContext& ctx, const float* heights, int w, int h, const CorrectParams& p,
                        float* offsets_out, CorrectReport* report, const CorrectProgress& progress)
{
    validate(p, w, h);
    const std::size_t n = std::size_t(w) * h;
    std::fill(offsets_out, offsets_out + 2 * n, 0.0f);
    CorrectReport rep;
    const FinestInput input = finest_input(heights, w, h, p);
    const std::vector<float>&texels = input.texels, &fix = input.fix;
    const LevelInput& finest = input.level;

    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        // The finest level's distortion at zero offsets decides whether
        // there is anything to do.
        std::vector<float> aniso, area, zero(2 * std::size_t(finest.grid.nx) * finest.grid.ny, 0.0f);
        {
            LevelSolver s(ctx, finest.grid, finest.z, finest.fix, p);
            s.upload(zero);
            rep.energy_before = s.energy(&aniso, &area);
        }
        double worst = 0.0;
        for (std::size_t i = 0; i < aniso.size(); ++i)
            worst = std::max({worst, double(aniso[i]) - 1.0, std::abs(double(area[i]) - 1.0)});
        summarise_both(aniso, area, rep.anisotropy_before, rep.area_before);
        const bool too_small =
            (p.periodic.x ? w < 2 : finest.grid.nx < 3) || (p.periodic.y ? h < 2 : finest.grid.ny < 3);
        if (worst <= p.threshold || too_small) {
            rep.skipped = true;
            rep.energy_after = rep.energy_before;
            rep.anisotropy_after = rep.anisotropy_before;
            rep.area_after = rep.area_before;
            if (report)
                *report = rep;
            return;
        }

        // The centre mesh needs room to move, as the corner one did.
        const bool polishing = p.corner_nodes && p.polish > 0 && (p.periodic.x ? w >= 2 : w >= 3) &&
                               (p.periodic.y ? h >= 2 : h >= 3);
        const auto sizes = pyramid_sizes(w, h, p.levels);
        double total_weight = 0.0, done = 0.0;
        for (const auto& s : sizes)
            total_weight += double(s.first) * s.second;
        std::vector<float> offsets;  // texture units, per node of the previous level
        NodeGrid previous;
        for (int L = int(sizes.size()) - 1; L >= 0; --L) {
            const int lw = sizes[L].first, lh = sizes[L].second;
            std::vector<float> lt, lf;
            if (L > 0) {
                lt = area_downsample(texels, w, h, lw, lh);
                if (!fix.empty())
                    lf = area_downsample(fix, w, h, lw, lh);
            }
            const LevelInput in = L > 0 ? level_input(lt, fix.empty() ? nullptr : &lf, lw, lh, w, p) : finest;
            std::vector<float> start =
                offsets.empty() ? std::vector<float>(2 * std::size_t(in.grid.nx) * in.grid.ny, 0.0f)
                                : upsample_offsets(offsets, previous, in.grid);
            to_texels(start, in.grid, true);
            LevelSolver s(ctx, in.grid, in.z, in.fix, p);
            s.upload(start);
            // The level starts from the upsampled offsets times 1, 3/4, 1/2,
            // 1/4 or 0, whichever has the least energy. At a finer level a
            // cliff is steeper, and the coarse offsets, whole, can crowd it
            // (1024^2 desert cliff: 26x the energy of zero offsets, while
            // half of them had 0.55x).
            double start_energy = std::numeric_limits<double>::quiet_NaN(), start_factor = 0.0;
            if (!offsets.empty()) {
                std::vector<float> best(start.size(), 0.0f), scaled(start.size());
                // The finest level's energy at zero offsets is the one
                // measured before.
                if (L > 0) {
                    s.upload(best);
                    start_energy = s.energy();
                } else
                    start_energy = rep.energy_before;
                for (double factor : {1.0, 0.75, 0.5, 0.25}) {
                    for (std::size_t i = 0; i < start.size(); ++i)
                        scaled[i] = float(factor * start[i]);
                    s.upload(scaled);
                    const double e = s.energy();
                    if (std::isfinite(e) && e < start_energy) {
                        start_energy = e;
                        start_factor = factor;
                        best.swap(scaled);
                    }
                }
                s.upload(best);
            }
            const auto level_t0 = std::chrono::steady_clock::now();
            const double weight = double(lw) * lh / total_weight;
            // A level's share of the progress: the iterations done of a fixed
            // count, or (until the tolerance) how far the relative energy
            // change has fallen from its first value towards the tolerance,
            // on a log scale; never backwards, never 100% before the end.
            double level_done = 0.0, first_rel = 0.0;
            const int fixed = p.iterations;
            CorrectLevel lv = s.solve(
                [&](int it, double rel) {
                    double f = fixed > 0 ? double(it) / fixed : double(it) / p.max_iterations;
                    if (fixed == 0 && std::isfinite(rel) && rel > 0.0) {
                        if (first_rel == 0.0)
                            first_rel = rel;
                        if (first_rel > p.tolerance && rel < first_rel)
                            f = std::max(f, std::log(first_rel / rel) / std::log(first_rel / p.tolerance));
                    }
                    level_done = std::max(level_done, std::min(f, 0.99));
                    if (progress)
                        progress(done + weight * level_done);
                },
                // Every level to the same tolerance: measured on a 1024^2 wall,
                // coarse levels 3x looser cost the finest level 1.5x the
                // iterations, 3x tighter cost more than they saved. Only the
                // finest stops on a predicted fall: a coarser level's end is
                // the next one's start, to which a steep map's finest level
                // is sensitive (nx_brickfloor 1024^2: 153 iterations instead
                // of 119 when the coarser levels stopped on predictions).
                p.tolerance, start_energy, L > 0, L == 0 && p.predict_stop);
            lv.start_factor = start_factor;
            lv.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - level_t0).count();
            done += weight;
            if (progress && !(L == 0 && polishing))
                progress(std::min(1.0, done));
            s.download(offsets);
            to_texels(offsets, in.grid, false);
            previous = in.grid;
            if (L == 0) {
                // The device still holds the final offsets: their energy is
                // the level's end and the result's, with the statistics.
                rep.energy_after = lv.energy_end = s.energy(&aniso, &area);
                stop_if_cancelled();  // (the host's passes after the last level: tens of ms each at 1024^2)
                summarise_both(aniso, area, rep.anisotropy_after, rep.area_after);
            }
            rep.levels.push_back(lv);
        }
        stop_if_cancelled();
        std::vector<float> out = texel_offsets(offsets, finest.grid);
        if (polishing) {
            rep.polish = polish_mesh(ctx, texels, fix, w, h, p, out);
            if (progress)
                progress(1.0);
        }
        std::copy(out.begin(), out.end(), offsets_out);
    } catch (const cl::Error& e) {
        throw opencl_error("correction", e);
    }
    if (report)
        *report = rep;
}

double correction_energy(ComputeContext& ctx, const float* heights, int w, int h, const CorrectParams& p,
                         const float* node_offsets, DistortionStats* anisotropy, DistortionStats* area)
{
    validate(p, w, h);
    const LevelInput in = finest_input(heights, w, h, p).level;
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        std::vector<float> start(node_offsets, node_offsets + 2 * std::size_t(in.grid.nx) * in.grid.ny);
        to_texels(start, in.grid, true);
        LevelSolver s(ctx, in.grid, in.z, in.fix, p);
        s.upload(start);
        std::vector<float> an, ar;
        const double e = s.energy(&an, &ar);
        if (anisotropy)
            *anisotropy = summarise(an);
        if (area)
            *area = summarise(ar);
        return e;
    } catch (const cl::Error& e) {
        throw opencl_error("correction", e);
    }
}

}  // namespace relief::host

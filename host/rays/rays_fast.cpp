// SPDX-License-Identifier: Apache-2.0
// Radial ray integration along the chains of rational directions
// (docs/design.md §4.3; kernels/rays_fast.cl): per direction, period sums
// and chain windows, at a cost independent of the radius.
#include <algorithm>
#include <cmath>
#include <mutex>
#include <numeric>
#include <string>
#include <vector>

#include "errors.h"
#include "field_ops.h"
#include "rays/rays_parts.h"
#include "fft/fft_plan.h"
#include "device/queue_wait.h"

namespace relief::host {

namespace {

// One period of a rational direction, as the fast kernels read it.
struct PeriodTable {
    std::vector<cl_int2> offsets;
    std::vector<cl_float4> data;  // (extent x, extent y, length, mid-distance)
    std::vector<cl_float4> cut;   // cut at the partial length: (l', l'/l, l' * mid', 0)
    std::vector<cl_int> linear;   // offsets as index steps in a row-major image
    double w0 = 0, w1 = 0;        // sum of lengths, of length * mid-distance
    double pw0 = 0, pw1 = 0;      // the same over the partial last period
    double partial = 0;           // R - K*L
    int whole = 0;                // K
};

PeriodTable period_table(const RationalDirection& d, double radius, int width)
{
    PeriodTable t;
    const double L = d.length();
    t.whole = int(std::floor(radius / L));
    t.partial = radius - t.whole * L;
    if (t.partial < 1e-9 * L)
        t.partial = 0;  // walk_rational_ray makes no empty last period either
    for (const RaySegment& s : walk_ray(d.angle(), L)) {
        const double len = s.t_out - s.t_in, mid = 0.5 * (s.t_in + s.t_out);
        t.offsets.push_back(cl_int2{{s.ox, s.oy}});
        t.data.push_back(cl_float4{{float(s.ext_x), float(s.ext_y), float(len), float(mid)}});
        t.linear.push_back(cl_int(s.oy * width + s.ox));
        t.w0 += len;
        t.w1 += len * mid;
        const double cut = std::clamp(t.partial - s.t_in, 0.0, len);
        t.cut.push_back(cl_float4{{float(cut), float(cut / len), float(cut * (s.t_in + 0.5 * cut)), 0.0f}});
        t.pw0 += cut;
        t.pw1 += cut * (s.t_in + 0.5 * cut);
    }
    return t;
}

// First texels of the chains q, q + (a, b), ...: under periodic boundaries
// the chains are cycles of equal length (one representative each); under
// clip they start where q - (a, b) leaves the image.
// The most steps a chain of direction d takes: a periodic chain's cycle
// (see chain_starts), or, clipped, until it leaves the image (every step
// moves at least one texel along x or y).
long long chain_length(const RationalDirection& d, int w, int h, bool periodic)
{
    if (!periodic)
        return std::max(w, h);
    const long long gy = std::gcd<long long>(std::abs(d.b), h);
    const long long shift = ((long long)(d.a) * (h / gy)) % w;
    const long long gx = std::gcd<long long>((shift + w) % w, w);
    return (long long)w * h / (gx * gy);
}

std::vector<cl_int2> chain_starts(const RationalDirection& d, int w, int h, bool periodic, int& cycle)
{
    std::vector<cl_int2> starts;
    if (periodic) {
        // A cycle visits the rows y + m*b, i.e. every row of its class modulo
        // gy = gcd(b, H), and returns to its row after H/gy steps, moved by
        // a*H/gy columns; so it meets row y < gy in the columns of one class
        // modulo gx = gcd(a*H/gy mod W, W).
        const long long gy = std::gcd<long long>(std::abs(d.b), h);
        const long long shift = ((long long)(d.a) * (h / gy)) % w;
        const long long gx = std::gcd<long long>((shift + w) % w, w);
        for (long long y = 0; y < gy; ++y)
            for (long long x = 0; x < gx; ++x)
                starts.push_back(cl_int2{{int(x), int(y)}});
        const long long n = (long long)w * h;
        cycle = int(n / (long long)starts.size());
        if ((long long)cycle * (long long)starts.size() != n)
            throw Error("internal error: chain cycles do not cover the texture");
        return starts;
    }
    cycle = 0;
    int x0 = 0, x1 = 0;  // the columns whose predecessor is left or right of the image
    if (d.a > 0)
        x1 = std::min(d.a, w);
    else if (d.a < 0)
        x0 = std::max(w + d.a, 0), x1 = w;
    for (int y = 0; y < h; ++y)
        for (int x = x0; x < x1; ++x)
            starts.push_back(cl_int2{{x, y}});
    int y0 = 0, y1 = 0;
    if (d.b > 0)
        y1 = std::min(d.b, h);
    else if (d.b < 0)
        y0 = std::max(h + d.b, 0), y1 = h;
    for (int y = y0; y < y1; ++y)
        for (int x = 0; x < w; ++x)
            if (x < x0 || x >= x1)
                starts.push_back(cl_int2{{x, y}});
    return starts;
}

// The texels whose rays, in every direction, stay in a w x h image: there
// the clip result is the FFT's (inclusive; x0 > x1 when there are none).
cl_int4 whole_ray_rect(const RayParams& p, int w, int h)
{
    int min_x = 0, max_x = 0, min_y = 0, max_y = 0;
    for_each_packed_direction(p,
                              [&](int, const std::vector<cl_int2>& offsets, const std::vector<cl_float4>&) {
                                  for (const cl_int2& o : offsets) {
                                      min_x = std::min(min_x, o.s[0]);
                                      max_x = std::max(max_x, o.s[0]);
                                      min_y = std::min(min_y, o.s[1]);
                                      max_y = std::max(max_y, o.s[1]);
                                  }
                              });
    return cl_int4{{-min_x, -min_y, w - 1 - max_x, h - 1 - max_y}};
}

}  // namespace

void integrate_rays_chains(ComputeContext& ctx, const DeviceSlopes& slopes, const RayParams& p,
                           float* height_out, const Progress& progress, RayReport* report)
{
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    const bool periodic = p.boundary == RayBoundary::Periodic;
    const bool fp64 = ctx.fp64() && !p.force_float;
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    // Clip: where every ray stays in the image, the result is the periodic
    // convolution's (the same walks, nothing wraps); chains walk only the
    // band around it. The FFT runs first, so that its buffers are gone
    // before the chains' are made.
    cl_int4 fft_rect{{0, 0, -1, -1}};
    std::vector<float> fft_values;
    double chain_share = 1.0;
    // (Chains alone where the transform cannot be planned: FftPlan::unsupported.)
    const bool transposed = w == 1;
    if (!periodic && p.clip_by_fft && FftPlan::unsupported(transposed ? h : w, transposed ? 1 : h).empty()) {
        RayParams rational = p;
        rational.directions = DirectionSet::Rational;
        fft_rect = whole_ray_rect(rational, w, h);
        if (fft_rect.s[0] <= fft_rect.s[2] && fft_rect.s[1] <= fft_rect.s[3]) {
            fft_values.resize(n);
            chain_share = 0.8;
            DeviceSlopes shared = slopes;
            fft_ray_sums(
                c, shared, false, rational, [&] { return fft_values.data(); },
                [&](double f) {
                    if (progress)
                        progress((1.0 - chain_share) * f);
                });
        } else {
            fft_rect = cl_int4{{0, 0, -1, -1}};
        }
    }
    try {
        const auto dirs = rational_directions(p.rays, p.phase);
        // CPUs walk several neighbouring chains per work-item (cache reuse),
        // unless that makes a work-item loop longer than the device allows
        // (each lane: its first window of K periods, then its walk).
        std::uint64_t per_lane = 0;
        for (const RationalDirection& d : dirs)
            per_lane =
                std::max<std::uint64_t>(per_lane, std::uint64_t(period_table(d, p.radius, w).whole) + 1 +
                                                      std::uint64_t(chain_length(d, w, h, periodic)));
        int lanes = ctx.device().is_gpu ? 1 : 16;
        if (lanes > 1 && !c.loops_fit(per_lane * std::uint64_t(lanes)))
            lanes = 1;
        if (!c.loops_fit(per_lane))
            throw Error("ray integration of a " + std::to_string(w) + "x" + std::to_string(h) +
                        " map walks chains of up to " + std::to_string(per_lane) +
                        " steps in one work-item, more than this device lets a work-item loop (it "
                        "stops loops after " +
                        std::to_string(c.loop_limit()) +
                        " iterations, as Mesa's llvmpipe does); use another OpenCL device");
        cl::Program& prog = c.program("rays_fast.cl", std::string(fp64 ? "-DRELIEF_FP64 " : "") +
                                                          "-DRELIEF_LANES=" + std::to_string(lanes));
        cl::Buffer sums = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float4) * n, "ray integration");
        cl::Buffer tail = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * n, "ray integration");
        cl::Buffer accum = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * n, "ray integration");
        cl::Buffer out = c.buffer(CL_MEM_WRITE_ONLY, sizeof(float) * n, "ray integration");
        c.fill(accum, 0.0f, 0, sizeof(cl_float2) * n);
        RayReport skipped;
        int tiles_x = 0;
        cl::Buffer active = active_tiles(c, slopes, p.radius + 2.0, periodic, p.skip_flat, tiles_x, skipped);
        if (report)
            *report = skipped;

        cl::Kernel period_sums(prog, "rays_period_sums");
        cl::Kernel windows(prog, "rays_chain_windows");
        cl::Kernel cycles(prog, "rays_cycle_windows");
        const std::vector<double> dir_weight =
            angular_weights(ray_angles(p.rays, p.phase, DirectionSet::Rational));
        for (std::size_t j = 0; j < dirs.size(); ++j) {
            const RationalDirection& d = dirs[j];
            PeriodTable t = period_table(d, p.radius, w);
            int cycle = 0;
            std::vector<cl_int2> starts = chain_starts(d, w, h, periodic, cycle);
            cl::Buffer offsets = constant_buffer(c, t.offsets);
            cl::Buffer data = constant_buffer(c, t.data);
            cl::Buffer cut = constant_buffer(c, t.cut);
            cl::Buffer linear = constant_buffer(c, t.linear);
            cl::Buffer start_buf = constant_buffer(c, starts);
            const cl_int segs = cl_int(t.offsets.size());

            // The sums of q serve the chain points q - m (a, b), m = 0..K; none
            // is walked when q and q - K (a, b) both lie in the FFT's
            // rectangle (it is convex).
            const int rx = t.whole * d.a, ry = t.whole * d.b;
            const cl_int4 unused{
                {std::max(fft_rect.s[0], fft_rect.s[0] + rx), std::max(fft_rect.s[1], fft_rect.s[1] + ry),
                 std::min(fft_rect.s[2], fft_rect.s[2] + rx), std::min(fft_rect.s[3], fft_rect.s[3] + ry)}};
            std::size_t sums_needed = n;
            if (unused.s[0] <= unused.s[2] && unused.s[1] <= unused.s[3])
                sums_needed -=
                    std::size_t(unused.s[2] - unused.s[0] + 1) * std::size_t(unused.s[3] - unused.s[1] + 1);
            const cl_float first_length = cl_float(std::min<double>(t.data[0].s[2], p.radius));
            set_args(period_sums, slopes.impl().buffer, cl_int(w), cl_int(h), cl_int(periodic), cl_int(d.a),
                     cl_int(d.b), segs, offsets, data, cut, linear, first_length, active, cl_int(kSkipTile),
                     cl_int(tiles_x), unused, sums, tail);
            c.launch(period_sums, sums_needed);

            if (periodic && fp64 && std::abs(d.a) < w && std::abs(d.b) < h) {
                // Cycles in double: the branch-free kernel (float re-anchors).
                set_args(cycles, cl_int(w), cl_int(h), cl_int(d.a), cl_int(d.b), start_buf,
                         cl_int(starts.size()), cl_int(cycle), cl_int(t.whole), cl_float(d.length()),
                         cl_float(t.w0), cl_float(t.w1), cl_float(t.pw0), cl_float(t.pw1),
                         cl_float(t.partial), cl_float(std::min<double>(t.data[0].s[2], p.radius)), sums,
                         tail, cl_float(dir_weight[j]), active, cl_int(kSkipTile), cl_int(tiles_x), accum);
                c.launch(cycles, (starts.size() + lanes - 1) / lanes);
            } else {
                set_args(windows, slopes.impl().buffer, cl_int(w), cl_int(h), cl_int(periodic), cl_int(d.a),
                         cl_int(d.b), start_buf, cl_int(starts.size()), cl_int(cycle), cl_int(t.whole),
                         cl_float(d.length()), cl_float(t.w0), cl_float(t.w1), cl_float(t.pw0),
                         cl_float(t.pw1), cl_float(t.partial), segs, offsets, data, sums, tail,
                         cl_int(fp64 ? 0 : std::max(1, p.float_reanchor)), cl_float(dir_weight[j]), active,
                         cl_int(kSkipTile), cl_int(tiles_x), fft_rect, accum);
                c.launch(windows, (starts.size() + lanes - 1) / lanes);
            }
            // The tables above go out of scope with this iteration.
            finish_asking(c.queue);
            if (progress)
                progress(1.0 - chain_share + chain_share * double(j + 1) / double(dirs.size()));
        }
        cl::Kernel finish(prog, "rays_finish");
        set_args(finish, accum, cl_int(n), out);
        c.launch(finish, n);
        read_asking(c.queue, out, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw opencl_error("fast ray", e);
    }
    for (int y = fft_rect.s[1]; y <= fft_rect.s[3]; ++y)
        std::copy(fft_values.begin() + std::ptrdiff_t(y) * w + fft_rect.s[0],
                  fft_values.begin() + std::ptrdiff_t(y) * w + fft_rect.s[2] + 1,
                  height_out + std::ptrdiff_t(y) * w + fft_rect.s[0]);
    remove_mean(height_out, n);
}

}  // namespace relief::host

#include "ray_stage.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "errors.h"
#include "fft_plan.h"
#include "field_ops.h"
#include "opencl_context.h"
#include "plan_cache.h"

namespace relief::host {

namespace {

struct PackedTables {
    std::vector<cl_int> dir_start;    // directions + 1
    std::vector<cl_int2> offsets;     // per segment
    std::vector<cl_float4> data;      // (ext x, ext y, weight, cumulative weight)
};

// Calls fn(j, offsets, data) with direction j's packed walk, one direction
// at a time: all directions' walks at once reached ~25 GB at rays=4096,
// radius=65536.
template <class Fn>
void for_each_packed_direction(const RayParams& p, Fn fn)
{
    const std::vector<double> dir_weight =
        angular_weights(ray_angles(p.rays, p.phase, p.directions));
    const std::vector<RationalDirection> rational =
        p.directions == DirectionSet::Rational ? rational_directions(p.rays, p.phase)
                                               : std::vector<RationalDirection>();
    const std::vector<double> angles = p.directions == DirectionSet::Rational
                                           ? std::vector<double>()
                                           : ray_angles(p.rays, p.phase, p.directions);
    std::vector<cl_int2> offsets;
    std::vector<cl_float4> data;
    for (int j = 0; j < p.rays; ++j) {
        const std::vector<RaySegment> walk = p.directions == DirectionSet::Rational
                                                 ? walk_rational_ray(rational[j], p.radius)
                                                 : walk_ray(angles[j], p.radius);
        offsets.clear();
        data.clear();
        double cumulative = 0.0;
        for (const RaySegment& s : walk) {
            const double weight = s.weight * dir_weight[j];
            cumulative += weight;
            offsets.push_back(cl_int2{{s.ox, s.oy}});
            data.push_back(cl_float4{{float(s.ext_x), float(s.ext_y), float(weight),
                                      float(cumulative)}});
        }
        fn(j, offsets, data);
    }
}

// An upper bound on the segments of all walks: a ray crosses at most
// |cos| + |sin| <= sqrt(2) texel edges per texel of length, plus its ends
// (and a rational walk splits one segment per period).
double walk_segments_bound(const RayParams& p)
{
    return double(p.rays) * (2.0 * std::sqrt(2.0) * p.radius + 4.0);
}

PackedTables pack_tables(ComputeContext::Impl& c, const RayParams& p)
{
    // The reference kernel reads every walk from one device table: refuse
    // what cannot be allocated before building it on the host.
    const double bytes = walk_segments_bound(p) * sizeof(cl_float4);
    if (bytes > double(c.buffer_limit()) || walk_segments_bound(p) > double(INT32_MAX))
        throw Error("rays=" + std::to_string(p.rays) + " and radius=" +
                    [&] { std::ostringstream r; r << p.radius; return r.str(); }() +
                    " need walk tables of up to " +
                    std::to_string(int(std::ceil(bytes / (1024.0 * 1024.0)))) +
                    " MiB, more than the device allows in one buffer (" +
                    std::to_string(c.buffer_limit() / (1024 * 1024)) +
                    " MiB); use impl=fast, or fewer rays or a shorter radius");
    PackedTables t;
    for_each_packed_direction(p, [&](int, const std::vector<cl_int2>& offsets,
                                     const std::vector<cl_float4>& data) {
        t.dir_start.push_back(cl_int(t.offsets.size()));
        t.offsets.insert(t.offsets.end(), offsets.begin(), offsets.end());
        t.data.insert(t.data.end(), data.begin(), data.end());
    });
    t.dir_start.push_back(cl_int(t.offsets.size()));
    return t;
}

template <class T>
cl::Buffer constant_buffer(ComputeContext::Impl& c, std::vector<T>& v)
{
    return c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(T) * v.size(),
                    "ray integration's walk tables", v.data());
}

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
        t.cut.push_back(cl_float4{{float(cut), float(cut / len),
                                   float(cut * (s.t_in + 0.5 * cut)), 0.0f}});
        t.pw0 += cut;
        t.pw1 += cut * (s.t_in + 0.5 * cut);
    }
    return t;
}

// First texels of the chains q, q + (a, b), ...: under periodic boundaries
// the chains are cycles of equal length (one representative each); under
// clip they start where q - (a, b) leaves the image.
std::vector<cl_int2> chain_starts(const RationalDirection& d, int w, int h, bool periodic,
                                  int& cycle)
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

// One flag per kSkipTile^2 tile: 1 where the rays of its texels may cross a
// non-zero slope (a non-flat tile within `reach` texels), 0 where they cannot.
cl::Buffer active_tiles(ComputeContext::Impl& c, const DeviceSlopes& slopes, double reach,
                        bool periodic, bool skip, int& tiles_x, RayReport& report)
{
    const int w = slopes.width(), h = slopes.height(), T = kSkipTile;
    tiles_x = (w + T - 1) / T;
    const int tiles_y = (h + T - 1) / T;
    const std::size_t n = std::size_t(tiles_x) * tiles_y;
    std::vector<cl_uchar> flags(n, 1);
    if (skip) {
        cl::Buffer nonflat = c.buffer(CL_MEM_WRITE_ONLY, n, "ray integration");
        cl::Kernel k(c.program("tiles.cl"), "nonflat_tiles");
        k.setArg(0, slopes.impl().buffer);
        k.setArg(1, cl_int(w));
        k.setArg(2, cl_int(h));
        k.setArg(3, cl_int(T));
        k.setArg(4, cl_int(tiles_x));
        k.setArg(5, cl_int(tiles_y));
        k.setArg(6, nonflat);
        c.queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(padded(n)),
                                     cl::NDRange(kGroupSize));
        std::vector<cl_uchar> any(n);
        c.queue.enqueueReadBuffer(nonflat, CL_TRUE, 0, n, any.data());
        // Dilate by the reach in tiles (a square covers the disk), along x
        // then along y; periodic textures wrap.
        const int r = int(std::ceil(reach / T));
        auto dilate = [&](std::vector<cl_uchar>& v, int len, int lines, bool along_x) {
            std::vector<cl_uchar> out(v.size(), 0);
            for (int l = 0; l < lines; ++l)
                for (int i = 0; i < len; ++i) {
                    const std::size_t at = along_x ? std::size_t(l) * tiles_x + i
                                                   : std::size_t(i) * tiles_x + l;
                    if (!v[at])
                        continue;
                    for (int d = -std::min(r, len); d <= std::min(r, len); ++d) {
                        int j = i + d;
                        if (periodic)
                            j = ((j % len) + len) % len;
                        else if (j < 0 || j >= len)
                            continue;
                        out[along_x ? std::size_t(l) * tiles_x + j : std::size_t(j) * tiles_x + l] = 1;
                    }
                }
            v.swap(out);
        };
        dilate(any, tiles_x, tiles_y, true);
        dilate(any, tiles_y, tiles_x, false);
        flags = any;
    }
    report.tiles = n;
    report.skipped = std::size_t(std::count(flags.begin(), flags.end(), cl_uchar(0)));
    return c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n, "ray integration", flags.data());
}

} // namespace

namespace {

// A = Kx (x) gx + Ky (x) gy, one circular convolution: the periodic
// result before its mean is removed, and the clip result wherever every ray
// stays in the image. The caller holds c.mutex. With `consume`, the slopes
// are let go once split into the transform's grids; the host memory for
// the result is asked of `sink` only after the grids are gone.
void fft_ray_sums(ComputeContext::Impl& c, DeviceSlopes& slopes, bool consume, const RayParams& p,
                  const HeightSink& sink, const Progress& progress)
{
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * h;
    if (n == 1) {
        sink()[0] = 0.0f;
        return;
    }
    // A one-texel-wide texture is a 1-D transform along y (as in Poisson).
    const bool transposed = w == 1;
    const int n0 = transposed ? h : w, n1 = transposed ? 1 : h;
    if (const std::string why = FftPlan::unsupported(n0, n1); !why.empty())
        throw Error("periodic rays: " + why + " (boundary=clip walks every ray instead)");
    const std::size_t stride = FftPlan::row_stride(n0);
    const std::size_t grid = stride * n1;

    // The kernels, mirrored (K'(o) = K(-o)) so that A = K' * g, wrapped.
    // They have a few taps per walk step: kept sparse, summed per tap in
    // walk order (in double), and scattered into a grid on the device one
    // at a time, rather than made as full grids here.
    std::unordered_map<std::size_t, std::size_t> slot;  // grid index -> tap
    std::vector<std::size_t> tap_index;
    std::vector<double> tap_x, tap_y;
    double total = 0.0;
    for_each_packed_direction(p, [&](int, const std::vector<cl_int2>& offsets,
                                     const std::vector<cl_float4>& data) {
        const std::size_t segs = data.size();
        const double dir_total = segs ? data[segs - 1].s[3] : 0.0;  // cumulative
        for (std::size_t s = 0; s < segs; ++s) {
            const double weight = data[s].s[2];
            const double after = dir_total - data[s].s[3];  // later segments' weights
            const double factor = 0.5 * weight + after;
            const int ox = ((-offsets[s].s[0]) % w + w) % w;
            const int oy = ((-offsets[s].s[1]) % h + h) % h;
            const std::size_t at = transposed ? std::size_t(oy) : std::size_t(oy) * stride + ox;
            auto [it, added] = slot.emplace(at, tap_index.size());
            if (added) {
                tap_index.push_back(at);
                tap_x.push_back(0.0);
                tap_y.push_back(0.0);
            }
            tap_x[it->second] += data[s].s[0] * factor;
            tap_y[it->second] += data[s].s[1] * factor;
        }
        total += dir_total;
    });
    if (!(total > 0.0)) {
        std::fill_n(sink(), n, 0.0f);
        return;
    }
    const std::size_t taps = tap_index.size();
    std::vector<cl_int> index(taps);
    std::vector<float> value_x(taps), value_y(taps);
    for (std::size_t t = 0; t < taps; ++t) {
        index[t] = cl_int(tap_index[t]);
        value_x[t] = float(tap_x[t]);
        value_y[t] = float(tap_y[t]);
    }
    try {
        cl::Program& spectral = c.program("poisson.cl");  // split and gather
        cl::Program& prog = c.program("rays_fft.cl");
        const std::size_t bytes = sizeof(float) * grid;
        cl::Buffer gx = c.buffer(CL_MEM_READ_WRITE, bytes, "ray integration");
        cl::Buffer gy = c.buffer(CL_MEM_READ_WRITE, bytes, "ray integration");
        const cl::NDRange local(kGroupSize);

        cl::Kernel split(spectral, "poisson_split");
        int a = 0;
        split.setArg(a++, slopes.impl().buffer);
        split.setArg(a++, cl_int(w));
        split.setArg(a++, cl_int(n0));
        split.setArg(a++, cl_int(n1));
        split.setArg(a++, cl_int(transposed));
        split.setArg(a++, cl_int(stride));
        split.setArg(a++, cl_int(0));
        split.setArg(a++, gx);
        split.setArg(a++, gy);
        c.queue.enqueueNDRangeKernel(split, cl::NullRange, cl::NDRange(padded(n)), local);
        if (consume) {
            split = cl::Kernel();  // the kernel holds its arguments too
            slopes.release();      // freed once the split has run
        }
        std::shared_ptr<FftPlan> plan = c.plans->fft(c, n0, n1, gx);
        plan->forward(gx);
        plan->forward(gy);

        // Transposed, the split put the y slopes in gx and the x slopes in gy.
        const std::vector<float>& first = transposed ? value_y : value_x;
        const std::vector<float>& second = transposed ? value_x : value_y;
        cl::Buffer taps_at = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(cl_int) * taps,
                                      "ray integration", index.data());
        cl::Buffer kernel_grid = c.buffer(CL_MEM_READ_WRITE, bytes, "ray integration");
        cl::Kernel scatter(prog, "rays_fft_scatter");
        scatter.setArg(0, kernel_grid);
        scatter.setArg(1, taps_at);
        scatter.setArg(3, cl_int(taps));
        auto make_kernel_spectrum = [&](const std::vector<float>& values) {
            cl::Buffer v = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * taps,
                                    "ray integration", values.data());
            c.queue.enqueueFillBuffer(kernel_grid, 0.0f, 0, bytes);
            scatter.setArg(2, v);
            c.queue.enqueueNDRangeKernel(scatter, cl::NullRange, cl::NDRange(padded(taps)), local);
            plan->forward(kernel_grid);
        };
        const std::size_t count = (stride / 2) * n1;
        make_kernel_spectrum(first);
        cl::Kernel multiply(prog, "rays_fft_multiply");
        multiply.setArg(0, gx);
        multiply.setArg(1, kernel_grid);
        multiply.setArg(2, cl_int(count));
        c.queue.enqueueNDRangeKernel(multiply, cl::NullRange, cl::NDRange(padded(count)), local);
        if (progress) {
            c.queue.finish();
            progress(0.5);
        }
        make_kernel_spectrum(second);
        cl::Kernel multiply_add(prog, "rays_fft_multiply_add");
        multiply_add.setArg(0, gx);
        multiply_add.setArg(1, gy);
        multiply_add.setArg(2, kernel_grid);
        multiply_add.setArg(3, cl_int(count));
        multiply_add.setArg(4, cl_float(-1.0 / total));
        c.queue.enqueueNDRangeKernel(multiply_add, cl::NullRange, cl::NDRange(padded(count)), local);
        plan->inverse(gx);
        scatter = multiply = multiply_add = cl::Kernel();
        kernel_grid = cl::Buffer();
        plan.reset();

        read_real_result(c, gx, gy, stride, w, h, sink);
        if (progress)
            progress(1.0);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the FFT ray stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }
}

// Periodic boundaries: the convolution, then the mean removed.
void integrate_rays_by_fft(ComputeContext& ctx, DeviceSlopes& slopes, bool consume, const RayParams& p,
                           const HeightSink& sink, const Progress& progress, RayReport* report)
{
    if (report)
        *report = RayReport{};
    float* out = nullptr;
    {
        std::lock_guard<std::mutex> lock(ctx.impl().mutex);
        fft_ray_sums(ctx.impl(), slopes, consume, p, [&] { return out = sink(); }, progress);
    }
    remove_mean(out, std::size_t(slopes.width()) * slopes.height());
}

// The texels whose rays, in every direction, stay in a w x h image: there
// the clip result is the FFT's (inclusive; x0 > x1 when there are none).
cl_int4 whole_ray_rect(const RayParams& p, int w, int h)
{
    int min_x = 0, max_x = 0, min_y = 0, max_y = 0;
    for_each_packed_direction(p, [&](int, const std::vector<cl_int2>& offsets,
                                     const std::vector<cl_float4>&) {
        for (const cl_int2& o : offsets) {
            min_x = std::min(min_x, o.s[0]);
            max_x = std::max(max_x, o.s[0]);
            min_y = std::min(min_y, o.s[1]);
            max_y = std::max(max_y, o.s[1]);
        }
    });
    return cl_int4{{-min_x, -min_y, w - 1 - max_x, h - 1 - max_y}};
}

} // namespace

void integrate_rays_fast(ComputeContext& ctx, DeviceSlopes&& slopes, const RayParams& p,
                         const HeightSink& out, const Progress& progress, RayReport* report)
{
    DeviceSlopes taken = std::move(slopes);
    if (p.boundary == RayBoundary::Periodic && p.periodic_by_fft) {
        if (p.rays < 1 || !(p.radius > 0.0))
            throw Error("ray integration needs rays >= 1 and radius > 0");
        integrate_rays_by_fft(ctx, taken, true, p, out, progress, report);
        return;
    }
    integrate_rays_fast(ctx, taken, p, out(), progress, report);
}

void integrate_rays_fast(ComputeContext& ctx, const DeviceSlopes& slopes, const RayParams& p,
                         float* height_out, const Progress& progress, RayReport* report)
{
    if (p.boundary == RayBoundary::Periodic && p.periodic_by_fft) {
        if (p.rays < 1 || !(p.radius > 0.0))
            throw Error("ray integration needs rays >= 1 and radius > 0");
        DeviceSlopes shared = slopes;
        integrate_rays_by_fft(ctx, shared, false, p, [&] { return height_out; }, progress, report);
        return;
    }
    if (p.rays < 1 || !(p.radius > 0.0))
        throw Error("ray integration needs rays >= 1 and radius > 0");
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    const bool periodic = p.boundary == RayBoundary::Periodic;
    const bool fp64 = ctx.device().has_fp64 && !p.force_float;
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
    if (!periodic && p.clip_by_fft &&
        FftPlan::unsupported(transposed ? h : w, transposed ? 1 : h).empty()) {
        RayParams rational = p;
        rational.directions = DirectionSet::Rational;
        fft_rect = whole_ray_rect(rational, w, h);
        if (fft_rect.s[0] <= fft_rect.s[2] && fft_rect.s[1] <= fft_rect.s[3]) {
            fft_values.resize(n);
            chain_share = 0.8;
            DeviceSlopes shared = slopes;
            fft_ray_sums(c, shared, false, rational, [&] { return fft_values.data(); }, [&](double f) {
                if (progress)
                    progress((1.0 - chain_share) * f);
            });
        } else {
            fft_rect = cl_int4{{0, 0, -1, -1}};
        }
    }
    try {
        // CPUs walk several neighbouring chains per work-item (cache reuse).
        const int lanes = ctx.device().is_gpu ? 1 : 16;
        cl::Program& prog =
            c.program("rays_fast.cl", std::string(fp64 ? "-DRELIEF_FP64 " : "") +
                                          "-DRELIEF_LANES=" + std::to_string(lanes));
        cl::Buffer sums = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float4) * n, "ray integration");
        cl::Buffer tail = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * n, "ray integration");
        cl::Buffer accum = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * n, "ray integration");
        cl::Buffer out = c.buffer(CL_MEM_WRITE_ONLY, sizeof(float) * n, "ray integration");
        c.queue.enqueueFillBuffer(accum, cl_float2{{0.0f, 0.0f}}, 0, sizeof(cl_float2) * n);
        RayReport skipped;
        int tiles_x = 0;
        cl::Buffer active = active_tiles(c, slopes, p.radius + 2.0, periodic, p.skip_flat,
                                         tiles_x, skipped);
        if (report)
            *report = skipped;

        cl::Kernel period_sums(prog, "rays_period_sums");
        cl::Kernel windows(prog, "rays_chain_windows");
        cl::Kernel cycles(prog, "rays_cycle_windows");
        const auto dirs = rational_directions(p.rays, p.phase);
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

            int a = 0;
            period_sums.setArg(a++, slopes.impl().buffer);
            period_sums.setArg(a++, cl_int(w));
            period_sums.setArg(a++, cl_int(h));
            period_sums.setArg(a++, cl_int(periodic));
            period_sums.setArg(a++, cl_int(d.a));
            period_sums.setArg(a++, cl_int(d.b));
            period_sums.setArg(a++, segs);
            period_sums.setArg(a++, offsets);
            period_sums.setArg(a++, data);
            period_sums.setArg(a++, cut);
            period_sums.setArg(a++, linear);
            period_sums.setArg(a++, cl_float(std::min<double>(t.data[0].s[2], p.radius)));
            period_sums.setArg(a++, active);
            period_sums.setArg(a++, cl_int(kSkipTile));
            period_sums.setArg(a++, cl_int(tiles_x));
            // The sums of q serve the chain points q - m (a, b), m = 0..K; none
            // is walked when q and q - K (a, b) both lie in the FFT's
            // rectangle (it is convex).
            const int rx = t.whole * d.a, ry = t.whole * d.b;
            const cl_int4 unused{{std::max(fft_rect.s[0], fft_rect.s[0] + rx),
                                  std::max(fft_rect.s[1], fft_rect.s[1] + ry),
                                  std::min(fft_rect.s[2], fft_rect.s[2] + rx),
                                  std::min(fft_rect.s[3], fft_rect.s[3] + ry)}};
            std::size_t sums_needed = n;
            if (unused.s[0] <= unused.s[2] && unused.s[1] <= unused.s[3])
                sums_needed -= std::size_t(unused.s[2] - unused.s[0] + 1) * std::size_t(unused.s[3] - unused.s[1] + 1);
            period_sums.setArg(a++, unused);
            period_sums.setArg(a++, sums);
            period_sums.setArg(a++, tail);
            c.queue.enqueueNDRangeKernel(period_sums, cl::NullRange, cl::NDRange(padded(sums_needed)),
                                         cl::NDRange(kGroupSize));

            if (periodic && fp64 && std::abs(d.a) < w && std::abs(d.b) < h) {
                // Cycles in double: the branch-free kernel (float re-anchors).
                a = 0;
                cycles.setArg(a++, cl_int(w));
                cycles.setArg(a++, cl_int(h));
                cycles.setArg(a++, cl_int(d.a));
                cycles.setArg(a++, cl_int(d.b));
                cycles.setArg(a++, start_buf);
                cycles.setArg(a++, cl_int(starts.size()));
                cycles.setArg(a++, cl_int(cycle));
                cycles.setArg(a++, cl_int(t.whole));
                cycles.setArg(a++, cl_float(d.length()));
                cycles.setArg(a++, cl_float(t.w0));
                cycles.setArg(a++, cl_float(t.w1));
                cycles.setArg(a++, cl_float(t.pw0));
                cycles.setArg(a++, cl_float(t.pw1));
                cycles.setArg(a++, cl_float(t.partial));
                cycles.setArg(a++, cl_float(std::min<double>(t.data[0].s[2], p.radius)));
                cycles.setArg(a++, sums);
                cycles.setArg(a++, tail);
                cycles.setArg(a++, cl_float(dir_weight[j]));
                cycles.setArg(a++, active);
                cycles.setArg(a++, cl_int(kSkipTile));
                cycles.setArg(a++, cl_int(tiles_x));
                cycles.setArg(a++, accum);
                c.queue.enqueueNDRangeKernel(cycles, cl::NullRange,
                                             cl::NDRange(padded((starts.size() + lanes - 1) / lanes)),
                                             cl::NDRange(kGroupSize));
            } else {
                a = 0;
                windows.setArg(a++, slopes.impl().buffer);
                windows.setArg(a++, cl_int(w));
                windows.setArg(a++, cl_int(h));
                windows.setArg(a++, cl_int(periodic));
                windows.setArg(a++, cl_int(d.a));
                windows.setArg(a++, cl_int(d.b));
                windows.setArg(a++, start_buf);
                windows.setArg(a++, cl_int(starts.size()));
                windows.setArg(a++, cl_int(cycle));
                windows.setArg(a++, cl_int(t.whole));
                windows.setArg(a++, cl_float(d.length()));
                windows.setArg(a++, cl_float(t.w0));
                windows.setArg(a++, cl_float(t.w1));
                windows.setArg(a++, cl_float(t.pw0));
                windows.setArg(a++, cl_float(t.pw1));
                windows.setArg(a++, cl_float(t.partial));
                windows.setArg(a++, segs);
                windows.setArg(a++, offsets);
                windows.setArg(a++, data);
                windows.setArg(a++, sums);
                windows.setArg(a++, tail);
                windows.setArg(a++, cl_int(fp64 ? 0 : std::max(1, p.float_reanchor)));
                windows.setArg(a++, cl_float(dir_weight[j]));
                windows.setArg(a++, active);
                windows.setArg(a++, cl_int(kSkipTile));
                windows.setArg(a++, cl_int(tiles_x));
                windows.setArg(a++, fft_rect);
                windows.setArg(a++, accum);
                c.queue.enqueueNDRangeKernel(windows, cl::NullRange,
                                             cl::NDRange(padded((starts.size() + lanes - 1) / lanes)),
                                             cl::NDRange(kGroupSize));
            }
            // The tables above go out of scope with this iteration.
            c.queue.finish();
            if (progress)
                progress(1.0 - chain_share + chain_share * double(j + 1) / double(dirs.size()));
        }
        cl::Kernel finish(prog, "rays_finish");
        finish.setArg(0, accum);
        finish.setArg(1, cl_int(n));
        finish.setArg(2, out);
        c.queue.enqueueNDRangeKernel(finish, cl::NullRange, cl::NDRange(padded(n)),
                                     cl::NDRange(kGroupSize));
        c.queue.enqueueReadBuffer(out, CL_TRUE, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the fast ray stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }
    for (int y = fft_rect.s[1]; y <= fft_rect.s[3]; ++y)
        std::copy(fft_values.begin() + std::ptrdiff_t(y) * w + fft_rect.s[0],
                  fft_values.begin() + std::ptrdiff_t(y) * w + fft_rect.s[2] + 1,
                  height_out + std::ptrdiff_t(y) * w + fft_rect.s[0]);
    remove_mean(height_out, n);
}

void integrate_rays_reference(ComputeContext& ctx, const DeviceSlopes& slopes,
                              const RayParams& p, float* height_out, const Progress& progress,
                              RayReport* report)
{
    if (p.rays < 1 || !(p.radius > 0.0))
        throw Error("ray integration needs rays >= 1 and radius > 0");
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        PackedTables t = pack_tables(c, p);
        cl::Buffer dir_start = constant_buffer(c, t.dir_start);
        cl::Buffer offsets = constant_buffer(c, t.offsets);
        cl::Buffer data = constant_buffer(c, t.data);
        cl::Buffer out = c.buffer(CL_MEM_WRITE_ONLY, sizeof(float) * n, "ray integration");

        RayReport skipped;
        int tiles_x = 0;
        cl::Buffer active = active_tiles(c, slopes, p.radius + 2.0,
                                         p.boundary == RayBoundary::Periodic, p.skip_flat, tiles_x,
                                         skipped);
        if (report)
            *report = skipped;
        const bool fp64 = ctx.device().has_fp64 && !p.force_float;
        cl::Kernel k(c.program("rays_reference.cl", fp64 ? "-DRELIEF_FP64" : ""), "rays_reference");
        k.setArg(0, slopes.impl().buffer);
        k.setArg(1, w);
        k.setArg(2, h);
        k.setArg(5, cl_int(p.boundary == RayBoundary::Periodic));
        k.setArg(6, cl_int(p.rays));
        k.setArg(7, dir_start);
        k.setArg(8, offsets);
        k.setArg(9, data);
        k.setArg(10, active);
        k.setArg(11, cl_int(kSkipTile));
        k.setArg(12, cl_int(tiles_x));
        k.setArg(13, out);

        // Launch in bands of rows: each launch stays short (GPU watchdogs,
        // responsive progress) whatever the radius.
        const double work_per_row = double(w) * double(std::max<std::size_t>(t.offsets.size(), 1));
        const int band = int(std::clamp(2.0e8 / work_per_row, 1.0, double(h)));
        for (int row0 = 0; row0 < h; row0 += band) {
            const int rows = std::min(band, h - row0);
            k.setArg(3, row0);
            k.setArg(4, rows);
            c.queue.enqueueNDRangeKernel(k, cl::NullRange,
                                         cl::NDRange(padded(std::size_t(w) * rows)),
                                         cl::NDRange(kGroupSize));
            if (progress) {
                c.queue.finish();
                progress(double(row0 + rows) / h);
            }
        }
        c.queue.enqueueReadBuffer(out, CL_TRUE, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the ray stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }

    remove_mean(height_out, n);
}

std::uint64_t rays_fast_device_bytes(int w, int h, const RayParams& p, bool slopes_taken)
{
    const std::uint64_t n = std::uint64_t(w) * std::uint64_t(h), slopes = 8 * n;
    const std::uint64_t grid = sizeof(float) * FftPlan::row_stride(std::size_t(w)) * std::uint64_t(h);
    // gx, gy, one kernel grid and the transform's transposed spectrum
    const std::uint64_t convolution = 4 * grid;
    if (p.boundary == RayBoundary::Periodic && p.periodic_by_fft)
        return slopes_taken ? std::max(slopes + 2 * grid, convolution) : slopes + convolution;
    // chains: sums (float4), tail and accumulator (float2), out (float);
    // clip's convolution runs first and is freed before them
    const bool fft_first = p.boundary == RayBoundary::Clip && p.clip_by_fft;
    return slopes + std::max<std::uint64_t>(36 * n, fft_first ? convolution : 0);
}

} // namespace relief::host

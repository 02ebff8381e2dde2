// Distortion correction on the device: the coarse-to-fine driver around
// kernels/correct.cl (per-level iterations of four or more phases, energy
// reductions, tile skipping) and the before/after statistics.
#include "correct_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "correct_grid.h"
#include "errors.h"
#include "opencl_context.h"

namespace relief::host {

int CorrectReport::total_iterations() const
{
    int n = 0;
    for (const auto& l : levels)
        n += l.iterations;
    return n;
}

namespace {

constexpr int kTile = 16;  // nodes per tile side, CORRECT_TILE in correct.cl
// Tolerances from this up follow the energy by the nodes' summed falls;
// tighter ones recompute the energy every iteration.
constexpr double kGainTolerance = 1e-6;
// Quads per work-item on CPUs (CORRECT_NODES: line searches in lockstep,
// to overlap their dependency chains). Measured on PoCL with Brent's search
// (1024^2, 12 iterations, 2 cores): 1 quad 1.28-1.33 s, 2 quads 1.07-1.28 s,
// 4 quads 1.10-1.36 s, 8 quads 1.07-1.17 s, so 2.
constexpr int kCpuNodesPerItem = 2;

void validate(const CorrectParams& p, int w, int h)
{
    if (w < 1 || h < 1)
        throw Error("distortion correction needs a non-empty height map");
    check_index_range(w, h, "correct");
    if (!(p.scale > 0.0) || !std::isfinite(p.scale))
        throw Error("the displacement scale must be > 0");
    if (!(p.theta >= 0.0 && p.theta <= 20.0))
        throw Error("theta (the area exponent) must be in [0, 20]");
    if (!(p.tolerance > 0.0) || !(p.tolerance < 1.0))
        throw Error("the tolerance must be in (0, 1)");
    if (p.iterations < 0 || p.max_iterations < 1 || p.levels < 0)
        throw Error("iterations and levels must be >= 0");
    if (!(p.threshold >= 0.0))
        throw Error("the distortion threshold must be >= 0");
    if (!(p.relax >= 1.0 && p.relax < 2.0))
        throw Error("the over-relaxation factor must be in [1, 2)");
}

DistortionStats summarise(std::vector<float>& v)
{
    DistortionStats s;
    if (v.empty())
        return s;
    double sum = 0.0;
    for (float x : v)
        sum += x;
    s.mean = sum / double(v.size());
    const std::size_t k = std::min(v.size() - 1, std::size_t(std::ceil(0.95 * double(v.size()))) - 1);
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
    s.p95 = v[k];
    s.max = *std::max_element(v.begin(), v.end());
    return s;
}

// One level's device state and the kernels that work on it.
class LevelSolver {
public:
    LevelSolver(ComputeContext& ctx, const NodeGrid& g, const std::vector<float>& z,
                const std::vector<float>& fix, const CorrectParams& p)
        : c_(ctx.impl()), g_(g), p_(p), fp64_(ctx.device().has_fp64),
          nodes_per_item_(ctx.device().is_gpu ? 1 : kCpuNodesPerItem),
          nodes_(std::size_t(g.nx) * g.ny), use_fix_(!fix.empty())
    {
        const bool whole = p.theta == std::floor(p.theta);
        cl::Program& prog = c_.program(
            "correct.cl", std::string(fp64_ ? "-DRELIEF_FP64" : "") +
                              (whole ? " -DCORRECT_ITHETA=" + std::to_string(int(p.theta)) : "") +
                              " -DCORRECT_NODES=" + std::to_string(nodes_per_item_) +
                              " -DCORRECT_SEARCH=" + std::to_string(int(p.search)));
        energy_k_ = cl::Kernel(prog, "correct_energy");
        phase_k_ = cl::Kernel(prog, "correct_phase");
        active_k_ = cl::Kernel(prog, "correct_active");
        gain_sum_k_ = cl::Kernel(prog, "correct_gain_sum");
        const std::size_t esize = fp64_ ? sizeof(double) : sizeof(float);
        groups_ = padded(nodes_) / kGroupSize;
        c_buf_ = c_.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * nodes_, "distortion correction");
        z_buf_ = c_.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * nodes_, "distortion correction", z.data());
        fix_buf_ = use_fix_ ? c_.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                        sizeof(float) * nodes_, "distortion correction", fix.data())
                            : c_.buffer(CL_MEM_READ_ONLY, sizeof(float), "distortion correction");
        partial_ = c_.buffer(CL_MEM_READ_WRITE, esize * groups_, "distortion correction");
        gain_ = c_.buffer(CL_MEM_READ_WRITE, esize * nodes_, "distortion correction");
        tiles_x_ = (g.nx + kTile - 1) / kTile;
        tiles_y_ = (g.ny + kTile - 1) / kTile;
        for (int cy = 0; cy < (g.periodic && (g.ny & 1) && g.ny > 1 ? 3 : 2); ++cy)
            for (int cx = 0; cx < (g.periodic && (g.nx & 1) && g.nx > 1 ? 3 : 2); ++cx)
                phases_.push_back({cx, cy});
        const std::size_t tiles = std::size_t(tiles_x_) * tiles_y_;
        moved_ = c_.buffer(CL_MEM_READ_WRITE, tiles * phases_.size(), "distortion correction");
        active_ = c_.buffer(CL_MEM_READ_WRITE, tiles, "distortion correction");
        itheta_ = p.theta == std::floor(p.theta) ? int(p.theta) : -1;
    }

    // Offsets in texels of this level (float2 per node).
    void upload(const std::vector<float>& c)
    {
        c_.queue.enqueueWriteBuffer(c_buf_, CL_TRUE, 0, sizeof(cl_float2) * nodes_, c.data());
    }
    void download(std::vector<float>& c)
    {
        c.resize(2 * nodes_);
        c_.queue.enqueueReadBuffer(c_buf_, CL_TRUE, 0, sizeof(cl_float2) * nodes_, c.data());
    }

    // Total energy; with `stats`, per owned triangle (anisotropy, area ratio).
    // The statistics (16 bytes per node) come in chunks of at most one
    // device buffer; the partial sums are added in the same order whatever
    // the chunking.
    double energy(std::vector<float>* aniso = nullptr, std::vector<float>* area = nullptr)
    {
        const bool want = aniso != nullptr;
        const std::size_t esize = fp64_ ? sizeof(double) : sizeof(float);
        std::size_t chunk = padded(nodes_);
        if (want) {
            aniso->clear();
            area->clear();
            const std::size_t fit = c_.buffer_limit() / sizeof(cl_float4) / kGroupSize * kGroupSize;
            chunk = std::min(chunk, std::max(fit, kGroupSize));
        }
        cl::Buffer stats = c_.buffer(CL_MEM_WRITE_ONLY, want ? sizeof(cl_float4) * chunk : 16,
                                     "distortion correction's statistics");
        std::vector<float> st(want ? 4 * chunk : 0);
        double sum = 0.0;
        for (std::size_t first = 0; first < nodes_; first += chunk) {
            const std::size_t count = std::min(chunk, padded(nodes_ - first));
            int a = 0;
            energy_k_.setArg(a++, c_buf_);
            energy_k_.setArg(a++, z_buf_);
            energy_k_.setArg(a++, fix_buf_);
            energy_k_.setArg(a++, cl_int(use_fix_));
            energy_k_.setArg(a++, cl_int(g_.nx));
            energy_k_.setArg(a++, cl_int(g_.ny));
            energy_k_.setArg(a++, cl_int(g_.periodic));
            energy_k_.setArg(a++, float(p_.theta));
            energy_k_.setArg(a++, cl_int(itheta_));
            energy_k_.setArg(a++, partial_);
            energy_k_.setArg(a++, cl::Local(esize * kGroupSize));
            energy_k_.setArg(a++, stats);
            energy_k_.setArg(a++, cl_int(want));
            energy_k_.setArg(a++, cl_int(first));
            c_.queue.enqueueNDRangeKernel(energy_k_, cl::NullRange, cl::NDRange(count),
                                          cl::NDRange(kGroupSize));
            add_partials(count / kGroupSize, sum);
            if (want) {
                const std::size_t real = std::min(count, nodes_ - first);
                c_.queue.enqueueReadBuffer(stats, CL_TRUE, 0, sizeof(cl_float4) * real, st.data());
                for (std::size_t i = 0; i < real; ++i)
                    for (int t = 0; t < 2; ++t)
                        if (!std::isnan(st[4 * i + 2 * t])) {
                            aniso->push_back(st[4 * i + 2 * t]);
                            area->push_back(st[4 * i + 2 * t + 1]);
                        }
            }
        }
        return sum;
    }

    // The energy fall of the last iteration: the sum of the nodes' gains.
    double gain_sum()
    {
        int a = 0;
        gain_sum_k_.setArg(a++, gain_);
        gain_sum_k_.setArg(a++, cl_int(nodes_));
        gain_sum_k_.setArg(a++, partial_);
        gain_sum_k_.setArg(a++, cl::Local((fp64_ ? sizeof(double) : sizeof(float)) * kGroupSize));
        c_.queue.enqueueNDRangeKernel(gain_sum_k_, cl::NullRange, cl::NDRange(padded(nodes_)),
                                      cl::NDRange(kGroupSize));
        double sum = 0.0;
        add_partials(groups_, sum);
        return sum;
    }

    // Adds the first `groups` work-group partial sums to `sum`, in order.
    void add_partials(std::size_t groups, double& sum)
    {
        if (fp64_) {
            std::vector<double> part(groups);
            c_.queue.enqueueReadBuffer(partial_, CL_TRUE, 0, sizeof(double) * groups, part.data());
            for (double v : part)
                sum += v;
        } else {
            std::vector<float> part(groups);
            c_.queue.enqueueReadBuffer(partial_, CL_TRUE, 0, sizeof(float) * groups, part.data());
            for (float v : part)
                sum += v;
        }
    }

    // Iterates; returns what happened.
    // on_iteration(it, rel): after iteration it, with the relative energy
    // change it made.
    // start_energy: the energy of the uploaded offsets when the caller has
    // it (else NaN); with measure_end false the caller measures the end
    // energy itself (energy_end is left NaN).
    CorrectLevel solve(const std::function<void(int, double)>& on_iteration, double tolerance,
                       double start_energy, bool measure_end)
    {
        CorrectLevel lv;
        lv.width = g_.width;
        lv.height = g_.height;
        const std::size_t tiles = std::size_t(tiles_x_) * tiles_y_;
        // Every tile runs the first time round.
        c_.queue.enqueueFillBuffer(moved_, cl_uchar(1), 0, tiles * phases_.size());
        double e = std::isnan(start_energy) ? energy() : start_energy;
        lv.energy_start = e;
        std::vector<cl_uchar> act(tiles);
        const int limit = p_.iterations > 0 ? p_.iterations : p_.max_iterations;
        // The energy falls by the sum of the nodes' falls (float fan
        // energies: exact to ~1e-7 of the energy); below that, a tolerance
        // needs the energy itself each iteration.
        const bool from_gains =
            !p_.energy_each_iteration && (p_.iterations > 0 || tolerance >= kGainTolerance);
        for (int it = 1; it <= limit; ++it) {
            if (from_gains && fp64_)
                c_.queue.enqueueFillBuffer(gain_, cl_double(0), 0, sizeof(double) * nodes_);
            else if (from_gains)
                c_.queue.enqueueFillBuffer(gain_, cl_float(0), 0, sizeof(float) * nodes_);
            for (std::size_t ph = 0; ph < phases_.size(); ++ph) {
                int a = 0;
                if (p_.skip_tiles) {
                    active_k_.setArg(a++, moved_);
                    active_k_.setArg(a++, cl_int(phases_.size()));
                    active_k_.setArg(a++, cl_int(tiles_x_));
                    active_k_.setArg(a++, cl_int(tiles_y_));
                    active_k_.setArg(a++, cl_int(g_.periodic));
                    active_k_.setArg(a++, active_);
                    c_.queue.enqueueNDRangeKernel(active_k_, cl::NullRange,
                                                  cl::NDRange(padded(tiles)),
                                                  cl::NDRange(kGroupSize));
                    c_.queue.enqueueReadBuffer(active_, CL_TRUE, 0, tiles, act.data());
                    for (cl_uchar v : act)
                        lv.tile_phases_run += v != 0;
                } else {
                    c_.queue.enqueueFillBuffer(active_, cl_uchar(1), 0, tiles);
                    lv.tile_phases_run += tiles;
                }
                lv.tile_phases += tiles;
                c_.queue.enqueueFillBuffer(moved_, cl_uchar(0), ph * tiles, tiles);
                a = 0;
                phase_k_.setArg(a++, c_buf_);
                phase_k_.setArg(a++, z_buf_);
                phase_k_.setArg(a++, fix_buf_);
                phase_k_.setArg(a++, cl_int(use_fix_));
                phase_k_.setArg(a++, cl_int(g_.nx));
                phase_k_.setArg(a++, cl_int(g_.ny));
                phase_k_.setArg(a++, cl_int(g_.periodic));
                phase_k_.setArg(a++, cl_int(phases_[ph].first));
                phase_k_.setArg(a++, cl_int(phases_[ph].second));
                phase_k_.setArg(a++, cl_int(tiles_x_));
                phase_k_.setArg(a++, active_);
                phase_k_.setArg(a++, moved_);
                phase_k_.setArg(a++, cl_int(ph * tiles));
                phase_k_.setArg(a++, float(p_.theta));
                phase_k_.setArg(a++, cl_int(itheta_));
                phase_k_.setArg(a++, float(p_.relax));
                phase_k_.setArg(a++, gain_);
                c_.queue.enqueueNDRangeKernel(phase_k_, cl::NullRange,
                                              cl::NDRange(std::size_t(tiles_x_) * 8 / nodes_per_item_,
                                                          std::size_t(tiles_y_) * 8),
                                              cl::NDRange(8 / nodes_per_item_, 8));
            }
            const double next = from_gains ? e - gain_sum() : energy();
            const double rel = (e - next) / std::max(std::abs(e), 1e-300);
            e = next;
            lv.iterations = it;
            if (on_iteration)
                on_iteration(it, rel);
            // An infinite energy (a flipped start, or one beyond the
            // device's range without fp64) is never "converged".
            if (p_.iterations == 0 && std::isfinite(e) && std::isfinite(rel) && rel < tolerance) {
                lv.converged = true;
                break;
            }
        }
        lv.energy_end = !measure_end ? std::numeric_limits<double>::quiet_NaN() : from_gains ? energy() : e;
        return lv;
    }

private:
    ComputeContext::Impl& c_;
    NodeGrid g_;
    const CorrectParams& p_;
    bool fp64_;
    int nodes_per_item_;
    std::size_t nodes_;
    bool use_fix_;
    std::size_t groups_ = 0;
    int tiles_x_ = 0, tiles_y_ = 0, itheta_ = -1;
    std::vector<std::pair<int, int>> phases_;
    cl::Kernel energy_k_, phase_k_, active_k_, gain_sum_k_;
    cl::Buffer c_buf_, z_buf_, fix_buf_, partial_, moved_, active_, gain_;
};

struct LevelInput {
    NodeGrid grid;
    std::vector<float> z, fix;  // per node: height in texels, fixation weight
};

LevelInput level_input(const std::vector<float>& texel_heights, const std::vector<float>* fix,
                       int w, int h, int finest_w, const CorrectParams& p)
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

std::vector<float> fix_weights(const CorrectParams& p, std::size_t n)
{
    return p.fix_weights ? std::vector<float>(p.fix_weights, p.fix_weights + n) : std::vector<float>();
}

void to_texels(std::vector<float>& c, const NodeGrid& g, bool forward)
{
    for (std::size_t i = 0; i < c.size(); i += 2) {
        c[i] = forward ? c[i] * g.width : c[i] / g.width;
        c[i + 1] = forward ? c[i + 1] * g.height : c[i + 1] / g.height;
    }
}

} // namespace

void correct_distortion(ComputeContext& ctx, const float* heights, int w, int h,
                        const CorrectParams& p, float* offsets_out, CorrectReport* report,
                        const CorrectProgress& progress)
{
    validate(p, w, h);
    const std::size_t n = std::size_t(w) * h;
    std::fill(offsets_out, offsets_out + 2 * n, 0.0f);
    CorrectReport rep;
    const std::vector<float> texels(heights, heights + n);
    const std::vector<float> fix = fix_weights(p, n);

    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        // The finest level's distortion at zero offsets decides whether
        // there is anything to do.
        const LevelInput finest = level_input(texels, p.fix_weights ? &fix : nullptr, w, h, w, p);
        std::vector<float> aniso, area, zero(2 * std::size_t(finest.grid.nx) * finest.grid.ny, 0.0f);
        {
            LevelSolver s(ctx, finest.grid, finest.z, finest.fix, p);
            s.upload(zero);
            rep.energy_before = s.energy(&aniso, &area);
        }
        double worst = 0.0;
        for (std::size_t i = 0; i < aniso.size(); ++i)
            worst = std::max({worst, double(aniso[i]) - 1.0, std::abs(double(area[i]) - 1.0)});
        rep.anisotropy_before = summarise(aniso);
        rep.area_before = summarise(area);
        const bool too_small = finest.grid.periodic ? (w < 2 || h < 2) : (finest.grid.nx < 3 || finest.grid.ny < 3);
        if (worst <= p.threshold || too_small) {
            rep.skipped = true;
            rep.energy_after = rep.energy_before;
            rep.anisotropy_after = rep.anisotropy_before;
            rep.area_after = rep.area_before;
            if (report)
                *report = rep;
            return;
        }

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
            const LevelInput in = L > 0 ? level_input(lt, fix.empty() ? nullptr : &lf, lw, lh, w, p)
                                        : finest;
            std::vector<float> start = offsets.empty()
                                           ? std::vector<float>(2 * std::size_t(in.grid.nx) * in.grid.ny, 0.0f)
                                           : upsample_offsets(offsets, previous, in.grid);
            to_texels(start, in.grid, true);
            LevelSolver s(ctx, in.grid, in.z, in.fix, p);
            s.upload(start);
            // The upsampled offsets start the level unless zero offsets are
            // better: at a much finer level, coarse offsets can crowd steep
            // detail that the coarse level did not see.
            double start_energy = std::numeric_limits<double>::quiet_NaN();
            if (!offsets.empty()) {
                const double e_up = s.energy();
                s.upload(std::vector<float>(start.size(), 0.0f));
                const double e_zero = s.energy();
                start_energy = e_zero;
                if (std::isfinite(e_up) && e_up <= e_zero) {
                    s.upload(start);
                    start_energy = e_up;
                }
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
                            f = std::max(f, std::log(first_rel / rel) /
                                                std::log(first_rel / p.tolerance));
                    }
                    level_done = std::max(level_done, std::min(f, 0.99));
                    if (progress)
                        progress(done + weight * level_done);
                },
                // Every level to the same tolerance: measured on a 1024^2 wall,
                // coarse levels 3x looser cost the finest level 1.5x the
                // iterations, 3x tighter cost more than they saved.
                p.tolerance, start_energy, L > 0);
            lv.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - level_t0).count();
            done += weight;
            if (progress)
                progress(std::min(1.0, done));
            s.download(offsets);
            to_texels(offsets, in.grid, false);
            previous = in.grid;
            if (L == 0) {
                // The device still holds the final offsets: their energy is
                // the level's end and the result's, with the statistics.
                rep.energy_after = lv.energy_end = s.energy(&aniso, &area);
                rep.anisotropy_after = summarise(aniso);
                rep.area_after = summarise(area);
            }
            rep.levels.push_back(lv);
        }
        const std::vector<float> out = texel_offsets(offsets, finest.grid);
        std::copy(out.begin(), out.end(), offsets_out);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the correction stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }
    if (report)
        *report = rep;
}

double correction_energy(ComputeContext& ctx, const float* heights, int w, int h,
                         const CorrectParams& p, const float* node_offsets,
                         DistortionStats* anisotropy, DistortionStats* area)
{
    validate(p, w, h);
    const std::size_t n = std::size_t(w) * h;
    const std::vector<float> texels(heights, heights + n);
    const std::vector<float> fix = fix_weights(p, n);
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        const LevelInput in = level_input(texels, p.fix_weights ? &fix : nullptr, w, h, w, p);
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
        throw Error(std::string("OpenCL error in the correction stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }
}

} // namespace relief::host

// SPDX-License-Identifier: Apache-2.0
#include "fft/plan_cache.h"

#include "poisson/poisson_stage.h"

#include "device/setup_times.h"

namespace relief::host {

PlanCache::Entry* PlanCache::find(bool dct, std::size_t n0, std::size_t n1)
{
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
        if (it->dct == dct && it->n0 == n0 && it->n1 == n1) {
            entries_.splice(entries_.begin(), entries_, it);
            return &entries_.front();
        }
    return nullptr;
}

void PlanCache::make_room(std::size_t bytes)
{
    std::size_t total = bytes;
    for (const Entry& e : entries_)
        total += e.bytes;
    while (total > max_bytes_ && !entries_.empty()) {
        total -= entries_.back().bytes;
        entries_.pop_back();  // a plan still in use lives on in its caller's pointer
    }
}

std::size_t PlanCache::size() const
{
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    return entries_.size();
}

bool PlanCache::keeps(std::size_t n0, std::size_t n1) const
{
    return sizeof(float) * FftPlan::row_stride(n0) * n1 <= max_plan_bytes_;
}

std::shared_ptr<FftPlan> PlanCache::fft(ComputeContext::Impl& c, std::size_t n0, std::size_t n1,
                                        cl::Buffer& buffer)
{
    SetupTimer timer(SetupTimer::Kind::Plans);  // waiting for a plan made ahead counts too
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    if (Entry* e = find(false, n0, n1))
        return e->fft;
    const std::size_t bytes = sizeof(float) * FftPlan::row_stride(n0) * n1;
    // (a plan over a non-smooth strided axis holds a second grid of its own)
    if (bytes > max_plan_bytes_)
        return std::make_shared<FftPlan>(c, n0, n1, buffer);
    make_room(2 * bytes);
    Entry e{false, n0, n1, 2 * bytes, c.buffer(CL_MEM_READ_WRITE, bytes, "an FFT plan"), nullptr, nullptr};
    e.fft = std::make_shared<FftPlan>(c, n0, n1, e.buffer);
    entries_.push_front(std::move(e));
    return entries_.front().fft;
}

std::shared_ptr<DctPlan> PlanCache::dct(ComputeContext::Impl& c, std::size_t n0, std::size_t n1)
{
    SetupTimer timer(SetupTimer::Kind::Plans);
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    if (Entry* e = find(true, n0, n1))
        return e->dct_plan;
    const std::size_t bytes = sizeof(float) * FftPlan::row_stride(n0) * n1;
    // (Recursive: the DCT takes its FFT plan from this cache while being made.)
    const DctPlan::FftOf fft_of = [&](cl::Buffer& work) { return fft(c, n0, n1, work); };
    if (bytes > max_plan_bytes_)
        return std::make_shared<DctPlan>(c, n0, n1, fft_of);
    make_room(2 * bytes);
    Entry e{true, n0, n1, 2 * bytes, cl::Buffer(), nullptr, nullptr};
    e.dct_plan = std::make_shared<DctPlan>(c, n0, n1, fft_of);
    entries_.push_front(std::move(e));
    return entries_.front().dct_plan;
}

void prepare_height(ComputeContext& ctx, int width, int height)
{
    if (width < 1 || height < 1)
        return;
    auto& c = ctx.impl();
    // as the Poisson stage lays the map out: a one-texel-wide map transposed
    const std::size_t n0 = width == 1 ? height : width, n1 = width == 1 ? 1 : height;
    // The plan first: it is what the height waits for (its kernels come
    // from the disk cache in milliseconds, when the stage needs them).
    // The DCT plan (free boundary) holds the FFT plan (periodic) of the same
    // size: planning it prepares both.
    if (n0 >= 2 && c.plans->keeps(n0, n1))
        c.plans->dct(c, n0, n1);
    c.program("poisson.cl");
}

SpectralPlan::SpectralPlan(ComputeContext::Impl& c, SpectralKind kind, std::size_t n0, std::size_t n1,
                           cl::Buffer& grid)
{
    switch (kind) {
    case SpectralKind::Fourier: fft_ = c.plans->fft(c, n0, n1, grid); break;
    case SpectralKind::Cosine: dct_ = c.plans->dct(c, n0, n1); break;
    case SpectralKind::FourierCosine:
        // Not cached itself (its FFT is): a work grid and four kernels.
        mixed_ = std::make_shared<DctPlan>(
            c, n0, n1, [&](cl::Buffer& work) { return c.plans->fft(c, n0, n1, work); }, DctPlan::Axes::Axis1);
        break;
    }
}

void SpectralPlan::forward(cl::Buffer& b) const
{
    fft_ ? fft_->forward(b) : dct_ ? dct_->forward(b) : mixed_->forward(b);
}

void SpectralPlan::inverse(cl::Buffer& b) const
{
    fft_ ? fft_->inverse(b) : dct_ ? dct_->inverse(b) : mixed_->inverse(b);
}

}  // namespace relief::host

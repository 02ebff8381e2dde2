// SPDX-License-Identifier: Apache-2.0
#pragma once
// FFT and DCT plans kept per device context between operations, so that the
// next map of the same size (a --batch, a UDIM set, a host calling relief in
// a loop) does not plan again: planning costs VkFFT a kernel build each
// time, more than the whole transform of a 512^2 map. Small plans only
// (their buffers stay allocated); the least recently used go first.
// Thread-safe: prepare_height() (poisson_stage.h) fills it on a thread of its own while a
// stage may be running. Included only by host/*.cpp.
#include <CL/opencl.hpp>

#include <cstddef>
#include <list>
#include <memory>
#include <mutex>

#include "fft/dct_plan.h"
#include "fft/fft_plan.h"
#include "device/opencl_context.h"

namespace relief::host {

class PlanCache {
public:
    // Plans whose buffers take more than `max_plan_bytes` are built for the
    // call only; the cache holds at most `max_bytes` of plan buffers.
    explicit PlanCache(std::size_t max_plan_bytes = std::size_t(64) << 20,
                       std::size_t max_bytes = std::size_t(256) << 20)
        : max_plan_bytes_(max_plan_bytes), max_bytes_(max_bytes)
    {
    }

    // The FFT plan for n0 x n1. A cached plan has a buffer of its own to be
    // built against; one too large to keep is built against `buffer` (any
    // buffer of FftPlan::row_stride(n0) * n1 floats; the plan keeps it alive).
    std::shared_ptr<FftPlan> fft(ComputeContext::Impl& c, std::size_t n0, std::size_t n1, cl::Buffer& buffer);
    // The DCT plan for n0 x n1.
    std::shared_ptr<DctPlan> dct(ComputeContext::Impl& c, std::size_t n0, std::size_t n1);

    std::size_t size() const;
    // Whether plans of n0 x n1 are small enough to keep.
    bool keeps(std::size_t n0, std::size_t n1) const;

private:
    struct Entry {
        bool dct;
        std::size_t n0, n1, bytes;
        cl::Buffer buffer;  // what an FFT plan was built against
        std::shared_ptr<FftPlan> fft;
        std::shared_ptr<DctPlan> dct_plan;
    };
    Entry* find(bool dct, std::size_t n0, std::size_t n1);
    void make_room(std::size_t bytes);
    std::size_t max_plan_bytes_, max_bytes_;
    // Recursive: a DCT plan takes its FFT plan from the cache while being made.
    mutable std::recursive_mutex mutex_;
    std::list<Entry> entries_;  // most recently used first
};

// The transform the boundaries take: along a periodic axis the Fourier
// series, along a free one the cosine series (its even extension).
enum class SpectralKind {
    Fourier,        // periodic on both axes: FftPlan, half spectrum in place
    Cosine,         // free on both: DctPlan, on a dense n0 x n1 grid
    FourierCosine,  // periodic along axis 0, free along axis 1: DctPlan::Axes::Axis1
};

// The kind's plan behind one forward/inverse, the transforms from the cache.
class SpectralPlan {
public:
    // `grid`: as PlanCache::fft() takes it (unused for the DCT).
    SpectralPlan(ComputeContext::Impl& c, SpectralKind kind, std::size_t n0, std::size_t n1,
                 cl::Buffer& grid);
    void forward(cl::Buffer& b) const;
    void inverse(cl::Buffer& b) const;
    // Floats per row of the grid the plan works on.
    static std::size_t row_stride(SpectralKind kind, std::size_t n0)
    {
        return kind == SpectralKind::Cosine ? n0 : FftPlan::row_stride(n0);
    }

private:
    std::shared_ptr<FftPlan> fft_;
    std::shared_ptr<DctPlan> dct_;
    std::shared_ptr<DctPlan> mixed_;
};

}  // namespace relief::host

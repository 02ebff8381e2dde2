// SPDX-License-Identifier: Apache-2.0
#pragma once
// How the least squares lays a w x h map on its transforms' n0 x n1 grid
// (docs/design.md §4.4): the transform each axis's boundary takes, and which
// texture axis is the grid's axis 0. Included only by host/*.cpp.
#include <cstddef>

#include "fft/plan_cache.h"
#include "poisson/poisson_stage.h"

namespace relief::host {

struct PoissonLayout {
    bool free_x = false, free_y = false;  // an axis one texel long takes the other's
    // Axis 0 of the grid is the texture's y: a one-texel-wide map (a 1-D
    // transform along axis 0), or a map free along x and periodic along y
    // (the periodic axis must be axis 0, the real FFT's).
    bool transposed = false;
    int n0 = 0, n1 = 0;
    SpectralKind kind = SpectralKind::Fourier;
    std::size_t stride = 0;  // floats per row of the grid
    bool periodic0() const { return !(transposed ? free_y : free_x); }
    bool periodic1() const { return !(transposed ? free_x : free_y); }
};

inline PoissonLayout poisson_layout(int w, int h, const PoissonParams& p)
{
    PoissonLayout l;
    l.free_x = p.boundary_x == PoissonBoundary::Free;
    l.free_y = p.boundary_y == PoissonBoundary::Free;
    if (w == 1)
        l.free_x = l.free_y;
    else if (h == 1)
        l.free_y = l.free_x;
    l.transposed = w == 1 || (l.free_x && !l.free_y);
    l.n0 = l.transposed ? h : w;
    l.n1 = l.transposed ? w : h;
    l.kind = l.free_x != l.free_y ? SpectralKind::FourierCosine
             : l.free_x           ? SpectralKind::Cosine
                                  : SpectralKind::Fourier;
    l.stride = SpectralPlan::row_stride(l.kind, std::size_t(l.n0));
    return l;
}

}  // namespace relief::host

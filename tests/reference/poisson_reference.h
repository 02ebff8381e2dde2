// SPDX-License-Identifier: Apache-2.0
#pragma once
// Golden model of least-squares integration (docs/design.md §4.4): Frankot–
// Chellappa projection in double with plain separable DFTs (O(N^3), for
// small test fields). Free boundaries integrate the even (mirror) extension
// of the texture across them (2W along a free x, 2H along a free y) on a
// torus and crop it, which is what the device's DCT formulation computes in
// a fraction of the work. Nyquist frequencies and the mean are dropped.
#include <vector>

namespace relief::reference {

struct PoissonSettings {
    bool periodic_x = true, periodic_y = true;  // per axis: periodic or free
    double highpass_sigma = 0.0;                // Gaussian sigma of the relief balance, 0 = off
};

// slopes: gx, gy per texel (row-major). Returns the zero-mean height.
std::vector<double> poisson(const std::vector<double>& slopes, int width, int height,
                            const PoissonSettings& settings);

// Weighted least squares (kernels/poisson_weighted.cl): the discrete
// least squares over edges to the right and lower neighbours (wrapping
// along a periodic axis), weights
// c_e = max(min(w_p, w_q), eps), targets mean(s g) + delta(q) - delta(p),
// s = w / max(w, eps), delta = poisson(s g) minus the unweighted discrete
// solution of mean(s g); plain conjugate gradients in double to a relative
// residual of 1e-12. Zero mean. Weights of all ones give poisson(g).
std::vector<double> poisson_weighted(const std::vector<double>& slopes, int width, int height,
                                     const std::vector<double>& weights, bool periodic_x, bool periodic_y,
                                     double eps);

}  // namespace relief::reference

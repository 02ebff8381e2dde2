#pragma once
// Golden model of least-squares integration (DESIGN.md §4.4): Frankot–
// Chellappa projection in double with plain separable DFTs (O(N^3), for
// small test fields). Free boundaries integrate the even (mirror) extension
// of the texture on a 2W x 2H torus and crop it, which is what the device's
// DCT formulation computes in a quarter of the work. Nyquist frequencies and
// the mean are dropped.
#include <vector>

namespace relief::reference {

struct PoissonSettings {
    bool periodic = true;
    double highpass_sigma = 0.0;  // Gaussian sigma of the relief balance, 0 = off
};

// slopes: gx, gy per texel (row-major). Returns the zero-mean height.
std::vector<double> poisson(const std::vector<double>& slopes, int width, int height,
                            const PoissonSettings& settings);

// Weighted discrete least squares (kernels/poisson_weighted.cl): edges to
// the right and lower neighbours, w_e = min of the two weights, c_e =
// max(w_e, eps), target (w_e / c_e) * mean slope; solved by plain conjugate
// gradients in double to a relative residual of 1e-12. Zero mean.
std::vector<double> poisson_weighted(const std::vector<double>& slopes, int width, int height,
                                     const std::vector<double>& weights, bool periodic,
                                     double eps);

} // namespace relief::reference

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

// Weighted least squares with the spectral gradient of poisson() (the
// derivative of the Frankot–Chellappa basis, as dense separable matrices):
// minimise sum_p c_p |grad h(p) - t_p|^2, c_p = max(w_p, eps), t_p =
// (w_p / c_p) g_p; plain conjugate gradients in double to a relative
// residual of 1e-12. Zero mean. Weights of all ones give poisson().
std::vector<double> poisson_weighted(const std::vector<double>& slopes, int width, int height,
                                     const std::vector<double>& weights, bool periodic,
                                     double eps);

} // namespace relief::reference

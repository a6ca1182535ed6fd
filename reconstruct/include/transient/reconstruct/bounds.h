// Sharp bounds of the Poisson-smoothed density of any measure with moments c
// (thesis prop. 8.4, Karlsson & Georgiou 2013).
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

// P_r(phi) = (1 - r^2) / (2*pi*|1 - r*exp(i*phi)|^2), the Poisson kernel, r in [0, 1).
double PoissonKernel(double r, double phase);

// For every phase, lower[n] <= (P_r * F)(phase[n]) <= upper[n] for every measure F whose
// moments are c, and both are attained by some such F. Requires C(c) positive definite and
// 0 < r < 1; returns false (outputs unspecified) when C(c) is not positive definite.
[[nodiscard]] bool PoissonBounds(std::span<const Complex> c, double r,
                                 std::span<const double> phases, std::span<double> lower,
                                 std::span<double> upper);

}  // namespace transient

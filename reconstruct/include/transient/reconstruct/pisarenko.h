// Pisarenko estimate (thesis alg. 8.2 and §8.4.1): a uniform component plus at most m Dirac
// returns that reproduce c_0..c_m exactly.
#pragma once

#include <array>
#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

struct PisarenkoEstimate {
  // Total mass of the uniform component, lambda_min(C(c)): its density is uniform / (2*pi)
  // per radian and its moments are (uniform, 0, ..., 0).
  double uniform = 0.0;
  int count = 0;                           // number of returns, 0..m
  std::array<double, kMaxOrder> phase{};   // radians in [0, 2*pi), ascending
  std::array<double, kMaxOrder> weight{};  // > 0
};

// Decomposes c into lambda_min * (uniform measure) + sum_l w_l delta_{phi_l}: the eigenvector
// of lambda_min gives the polynomial whose unit-circle roots are the phases, and a Vandermonde
// least-squares solve against (c_0 - lambda_min, c_1, ..., c_m) gives the weights; a few
// Gauss-Newton steps on those moment equations then polish phases and weights together.
// Returns false for non-finite input or c_0 <= 0. Exact for m-sparse measures
// (lambda_min = 0). Returns with weight <= 0 (rounding in degenerate cases) are dropped.
[[nodiscard]] bool Pisarenko(std::span<const Complex> c, PisarenkoEstimate* estimate);

}  // namespace transient

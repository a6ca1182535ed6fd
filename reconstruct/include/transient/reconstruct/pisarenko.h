// Pisarenko estimate (thesis alg. 8.2 and §8.4.1): a uniform component plus at most m Dirac
// returns that reproduce c_0..c_m exactly.
#pragma once

#include <array>
#include <span>
#include <vector>

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

// The tables of PisarenkoByLevinson's search on the unit circle for order m, shared by all
// pixels: e^{i (j - m/2) phi_g} for j = 0..m at the 16 (m+1) phases phi_g = 2 pi g / size.
class PisarenkoSearchGrid {
 public:
  explicit PisarenkoSearchGrid(int m);
  int order() const { return order_; }
  int size() const { return size_; }
  const double* real(int j) const { return re_.data() + j * size_; }
  const double* imag(int j) const { return im_.data() + j * size_; }
  double unit_real(int g) const { return unit_re_[g]; }  // cos phi_g
  double unit_imag(int g) const { return unit_im_[g]; }  // sin phi_g

 private:
  int order_;
  int size_;
  std::vector<double> re_, im_;  // (m+1) planes of size()
  std::vector<double> unit_re_, unit_im_;
};

// The same estimate as Pisarenko() by a faster route (optimized_pisarenko.cc): lambda_min by
// Newton's method on Levinson's recursion, the roots as sign changes on the unit circle, the
// least-squares systems by their normal equations. Returns false, leaving *estimate
// unspecified, wherever it cannot vouch for the result (including every input for which
// Pisarenko() returns false, and degenerate or nearly degenerate ones): run Pisarenko() then.
// grid.order() must be c.size() - 1.
[[nodiscard]] bool PisarenkoByLevinson(std::span<const Complex> c, const PisarenkoSearchGrid& grid,
                                       PisarenkoEstimate* estimate);

}  // namespace transient

// Cumulative MESE distribution F_D([0, phi]) in closed form (thesis §8.4.4, eq. 8.9).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/polynomial.h"

namespace transient {

// The closed form's real terms, for evaluating it at many phases:
// F(phi) = slope phi + sum_l weight_log[l] (log|w_l| - log|w_l(0)|) + weight_arg[l] (arg w_l -
// arg w_l(0)), w_l = 1 - (cos phi + i sin phi) (inverse_re[l] + i inverse_im[l]), whose real
// part is positive, so that arg w_l = atan(Im w_l / Re w_l); w_l(0) is w_l at phi = 0, taken with
// the same arithmetic as the other phases' so that F(0) = 0 exactly.
struct CumulativeTerms {
  int degree = 0;
  double slope = 0.0;
  std::array<double, kMaxOrder> inverse_re{}, inverse_im{}, weight_log{}, weight_arg{};
};

// Partial-fraction form of D(phi) = sum_l r_l / (exp(i*phi) - x_l) over the m roots x_l of the
// denominator polynomial (outside the unit circle) and their mirror images 1/conj(x_l)
// (inside). Each term integrates to a logarithm; we write it as Log(1 - z) with |z| < 1, the
// principal branch, which is continuous on all of [0, 2*pi] — no branch tracking needed.
//
// The partial fractions assume simple poles. When two roots (nearly) coincide the residues
// blow up and cancel badly, so Init checks the root separation and that the linear term
// integrates to c_0; if either fails, the cumulative is computed by adaptive Simpson
// quadrature of D instead (closed_form() is false) — slower, never wrong.
class MeseCumulative {
 public:
  // q from Levinson(). Returns false only for an invalid q (q_0 <= 0 or not finite). The roots
  // of the denominator polynomial by `method` (MeseRoots): the optimized kernel's kAberth finds
  // the same roots to rounding, without Eigen's Schur decomposition where it can.
  [[nodiscard]] bool Init(std::span<const Complex> q,
                          RootMethod method = RootMethod::kCompanionMatrix);

  // F_D([0, phi]) for phi in [0, 2*pi]; F(0) = 0 and F(2*pi) = c_0.
  double operator()(double phase) const;

  bool closed_form() const { return closed_form_; }

  // The same values at many phases, for the optimized kernels: out[n * stride] = F at phase
  // phases[n], whose cosines and sines are given (one table for all pixels). In closed form the
  // Log of each term is taken as log|w| and atan(Im w / Re w), w = 1 - e^{i phi}/x_l in the
  // right half-plane (|x_l| > 1). glibc's complex log is accurate to the last bit of log|w|
  // near |w| = 1 and so spends most of operator()'s time (sorting its terms for a compensated
  // sum), which a sum of c_0-sized terms does not need. Otherwise each phase by quadrature.
  void Evaluate(std::span<const double> phases, std::span<const double> cosines,
                std::span<const double> sines, float* out, int64_t stride) const;
  // The terms that Evaluate sums (closed form only).
  CumulativeTerms Terms() const;

 private:
  double Quadrature(double phase) const;

  int size_ = 0;     // m + 1
  double c0_ = 0.0;  // from inverse Levinson
  std::array<Complex, kMaxMoments> q_{};
  bool closed_form_ = false;
  int degree_ = 0;
  // Per root x_l: the pole, the coefficients of the Log terms of x_l (z = exp(i*phi)/x_l) and
  // of its mirror 1/conj(x_l) (z = exp(-i*phi)/conj(x_l)).
  std::array<Complex, kMaxOrder> outer_pole_{}, outer_coefficient_{}, inner_coefficient_{};
  // Log(1 - 1/x_l) for phi = 0, which only operator() subtracts: taken at its first call after
  // Init, not in Init (glibc's clog, with the sort of its compensated sum, was 8 % of the
  // optimized kernel's time, which sums Terms() instead). So an instance is not to be shared
  // between threads.
  mutable std::array<Complex, kMaxOrder> log_at_zero_{};
  mutable bool log_at_zero_ready_ = false;
  double slope_ = 0.0;  // c_0 / (2*pi)
};

}  // namespace transient

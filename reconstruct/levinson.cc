// Levinson's algorithm (thesis alg. 8.1) and its inverse (thesis alg. B.3).
#include "transient/reconstruct/levinson.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

#include "kernels_internal.h"

namespace transient {

namespace {

// Levinson's recursion with c_0 replaced by `c0`; with `indefinite_last`, its last step may
// have |d| > 1 (then q = (C - (c_0 - c0) I)^{-1} e_0 all the same, with q_0 < 0).
LevinsonOutcome LevinsonSteps(std::span<const Complex> c, double c0, bool indefinite_last,
                              std::span<Complex> q) {
  assert(c.size() == q.size() && !c.empty() && c.size() <= kMaxMoments);
  const int m = static_cast<int>(c.size()) - 1;
  if (!(c0 > 0.0) || !std::isfinite(c0)) return LevinsonOutcome::kFailed;
  q[0] = 1.0 / c0;
  std::array<Complex, kMaxMoments> reversed;
  bool indefinite = false;
  for (int l = 1; l <= m; ++l) {
    // d is the reflection coefficient of step l; |d| < 1 iff the leading (l+1)x(l+1) minor
    // of C(c) is positive definite (given that the l x l one is).
    Complex d = 0.0;
    for (int k = 0; k < l; ++k) d += q[k] * c[l - k];
    const double norm_d = std::norm(d);
    if (!(norm_d < 1.0)) {  // also catches NaN
      if (!(indefinite_last && l == m && norm_d > 1.0 && std::isfinite(norm_d))) {
        return LevinsonOutcome::kFailed;
      }
      indefinite = true;
    }
    const double scale = 1.0 / (1.0 - norm_d);
    for (int k = 0; k < l; ++k) reversed[k + 1] = std::conj(q[l - 1 - k]);
    reversed[0] = 0.0;
    q[l] = 0.0;
    for (int k = 0; k <= l; ++k) q[k] = scale * (q[k] - d * reversed[k]);
  }
  q[0] = Complex(q[0].real(), 0.0);  // real in exact arithmetic
  if (!std::isfinite(q[0].real())) return LevinsonOutcome::kFailed;
  return indefinite ? LevinsonOutcome::kLastStepIndefinite : LevinsonOutcome::kPositiveDefinite;
}

}  // namespace

bool Levinson(std::span<const Complex> c, std::span<Complex> q) {
  return LevinsonSteps(c, c[0].real(), /*indefinite_last=*/false, q) ==
         LevinsonOutcome::kPositiveDefinite;
}

LevinsonOutcome ShiftedLevinson(std::span<const Complex> c, double shift, std::span<Complex> q) {
  return LevinsonSteps(c, c[0].real() - shift, /*indefinite_last=*/true, q);
}

bool ToeplitzLambdaMin(std::span<const Complex> c, double* lambda_min_out, std::span<Complex> q_out,
                       ToeplitzStart start) {
  assert(c.size() == q_out.size() && !c.empty() && c.size() <= kMaxMoments);
  const int size = static_cast<int>(c.size());
  const double c0 = c[0].real();
  if (!(c0 > 0.0) || !std::isfinite(c0)) return false;
  std::array<Complex, kMaxMoments> q_storage, trial_storage;
  std::span<Complex> q(q_storage.data(), size), trial(trial_storage.data(), size);
  double below = -std::numeric_limits<double>::infinity();  // C - below I positive definite
  double above = c0;  // lambda_min <= e_0^* C e_0 = c_0; lowered to each iterate past it
  double lambda = 0.0;
  LevinsonOutcome outcome = ShiftedLevinson(c, lambda, q);
  if (outcome == LevinsonOutcome::kFailed) {
    // Beyond a leading minor's lambda_min. Gershgorin's bound on lambda_min is a start from
    // below, but a far one, from which Newton's first step overshoots past that minor's
    // lambda_min (a pole of f) and the bracket is bisected. kSearchBelowZero first tries
    // shifts below 0 growing fourfold from c_0 / 64: the first that the recursion passes
    // (positive definite, or past lambda_min only in its last step) starts Newton's steps.
    double off_diagonal = 0.0;
    for (int j = 1; j < size; ++j) off_diagonal += 2.0 * std::sqrt(std::norm(c[j]));
    const double gershgorin = c0 - off_diagonal - kToeplitzGershgorinMargin * c0;
    // |c_j|^2 overflows beyond ~1e154: no bound to start from or search to (the dense
    // eigen-solve decides; moments from float images never come near).
    if (!std::isfinite(gershgorin)) return false;
    above = lambda;
    if (start == ToeplitzStart::kSearchBelowZero) {
      // shift < 0: for a subnormal c_0, -c_0 / 64 rounds to -0, which growing would not move.
      for (double shift = -c0 / 64.0; shift < 0.0 && shift > gershgorin; shift *= 4.0) {
        outcome = ShiftedLevinson(c, shift, q);
        if (outcome != LevinsonOutcome::kFailed) {
          lambda = shift;
          break;
        }
        above = shift;  // a leading minor's lambda_min, so lambda_min too, is below it
      }
    }
    if (outcome == LevinsonOutcome::kFailed) {
      lambda = gershgorin;
      outcome = ShiftedLevinson(c, lambda, q);
      if (outcome != LevinsonOutcome::kPositiveDefinite) return false;
    }
  }
  // Newton's step estimates the distance left to lambda_min; rounding in Levinson's recursion
  // near a singular matrix keeps it from falling much below ~eps c_0, so stop at this, after
  // which the step itself is added (quadratic convergence: its own error is far smaller).
  const double tolerance = kToeplitzLambdaTolerance * c0;
  double lambda_min = std::numeric_limits<double>::quiet_NaN();
  // The iterate before lambda that a step reached, and q_0 there (RationalStep).
  bool has_previous = false;
  double previous_lambda = 0.0, previous_q0 = 0.0;
  for (int step = 0; step < kToeplitzLambdaMaxSteps; ++step) {
    if (outcome == LevinsonOutcome::kPositiveDefinite) {
      below = std::max(below, lambda);
    } else {
      above = std::min(above, lambda);
    }
    double norm = 0.0;
    for (int j = 0; j < size; ++j) norm += std::norm(q[j]);
    const double newton = q[0].real() / norm;
    if (std::abs(newton) <= tolerance) {
      lambda_min = lambda + newton;
      break;
    }
    double next = lambda + (has_previous ? RationalStep(newton, lambda - previous_lambda,
                                                        q[0].real() - previous_q0, norm)
                                         : newton);
    if (!(next > below && next < above)) {
      if (!(above - below > tolerance)) {
        lambda_min = 0.5 * (below + above);
        break;
      }
      next = std::isfinite(below) ? 0.5 * (below + above) : above - 2.0 * (above - lambda);
    }
    const LevinsonOutcome next_outcome = ShiftedLevinson(c, next, trial);
    if (next_outcome == LevinsonOutcome::kFailed) {
      if (next < lambda) {  // from above, within (lambda_min, lambda): singular to rounding
        lambda_min = next;
        break;
      }
      above = next;  // past the leading minor's lambda_min: stay at lambda, bisect
      continue;
    }
    has_previous = true;
    previous_lambda = lambda;
    previous_q0 = q[0].real();
    lambda = next;
    outcome = next_outcome;
    std::swap(q, trial);
  }
  if (!std::isfinite(lambda_min)) return false;
  std::copy(q.begin(), q.end(), q_out.begin());
  *lambda_min_out = lambda_min;
  return true;
}

namespace {

// Undoes Levinson's recursion (thesis alg. B.3) from q = q^{(m)} down to q^{(0)}: calls
// row(l, current) with q^{(l)} in current[0..l], for l = m, ..., 0.
template <typename Row>
void UndoLevinson(std::span<const Complex> q, Row&& row) {
  assert(!q.empty() && q.size() <= kMaxMoments);
  assert(q[0].real() > 0.0);
  const int m = static_cast<int>(q.size()) - 1;
  std::array<Complex, kMaxMoments> current, next;
  for (int j = 0; j <= m; ++j) current[j] = q[j];
  for (int l = m; l >= 0; --l) {
    row(l, current);
    if (l == 0) break;
    // p = (conj q_l, ..., conj q_0); undo one Levinson step: q^{(l-1)} = q^{(l)} - q_l/p_l * p.
    const Complex ratio = internal::Divide(current[l], std::conj(current[0]));
    for (int j = 0; j < l; ++j) next[j] = current[j] - ratio * std::conj(current[l - j]);
    for (int j = 0; j < l; ++j) current[j] = next[j];
  }
}

}  // namespace

void InverseLevinson(std::span<const Complex> q, std::span<Complex> c) {
  assert(c.size() == q.size());
  const int m = static_cast<int>(q.size()) - 1;
  // Row l of the lower triangular L holds q^{(l)} reversed: L_{l,j} = q^{(l)}_{l-j}, where
  // q^{(l)} = C^{(l)}(c)^{-1} e_0 for the leading (l+1)x(l+1) minor; then L C(c) is upper
  // triangular with unit diagonal, so c = C(c) e_0 = L^{-1} e_0.
  std::array<std::array<Complex, kMaxMoments>, kMaxMoments> lower;
  UndoLevinson(q, [&](int l, const std::array<Complex, kMaxMoments>& current) {
    for (int j = 0; j <= l; ++j) lower[l][j] = current[l - j];
  });
  for (int l = 0; l <= m; ++l) {
    Complex sum = (l == 0) ? Complex(1.0) : Complex(0.0);
    for (int j = 0; j < l; ++j) sum -= lower[l][j] * c[j];
    c[l] = internal::Divide(sum, lower[l][l]);
  }
  c[0] = Complex(c[0].real(), 0.0);
}

double InverseLevinsonZeroth(std::span<const Complex> q) {
  Complex q0_of_first_minor = 0.0;  // q^{(0)}_0 = 1 / c_0
  UndoLevinson(q, [&](int l, const std::array<Complex, kMaxMoments>& current) {
    if (l == 0) q0_of_first_minor = current[0];
  });
  // As InverseLevinson's first row: the same division, so the same c_0 to the last bit.
  return internal::Divide(Complex(1.0), q0_of_first_minor).real();
}

}  // namespace transient

// Levinson's algorithm for q = C^{-1}(c) e_0 (thesis alg. 8.1) and its inverse (thesis alg. B.3).
#pragma once

#include <cmath>
#include <complex>
#include <limits>
#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

// Solves C(c) q = e_0 for the Hermitian Toeplitz matrix C(c) of c = (c_0, ..., c_m) in O(m^2).
// Returns false, leaving q unspecified, when C(c) is not positive definite: c_0 <= 0, a
// reflection coefficient |d| >= 1, or a non-finite value. q and c have the same size m+1.
// Only Re c_0 is read. On success q_0 = e_0^* C^{-1} e_0 > 0 is real.
[[nodiscard]] bool Levinson(std::span<const Complex> c, std::span<Complex> q);

// Levinson's recursion for C(c) - shift I, also just past lambda_min (Newton's method on it
// finds lambda_min: ToeplitzLambdaMin below):
// - kPositiveDefinite: C(c) - shift I is positive definite, and q = (C(c) - shift I)^{-1} e_0
//   with q_0 > 0;
// - kLastStepIndefinite: its leading m x m minor is positive definite and C(c) - shift I is
//   not, but is invertible: q as above, with q_0 < 0 (lambda_min < shift < the minor's);
// - kFailed: neither (shift at or beyond the minor's lambda_min, singular, or not finite).
enum class LevinsonOutcome { kPositiveDefinite, kLastStepIndefinite, kFailed };
[[nodiscard]] LevinsonOutcome ShiftedLevinson(std::span<const Complex> c, double shift,
                                              std::span<Complex> q);

// lambda_min of C(c) by Newton's method on ShiftedLevinson (Cybenko and Van Loan 1986; the
// derivation is in optimized_pisarenko.cc's header), or, once a step has reached an iterate,
// by a rational model of q_0 (RationalStep below): each step's outcome says on which side of
// lambda_min its iterate is, and a step that would leave the bracket known so far bisects it
// instead. Stops once Newton's step is below kToeplitzLambdaTolerance c_0 (after adding it: the
// convergence is quadratic), within kToeplitzLambdaMaxSteps recursions. The steps start at 0, or
// where the recursion fails there at Gershgorin's bound (kGershgorin, the Pisarenko kernels' start)
// or at the first of -c_0/64, -c_0/16, ... that it passes (kSearchBelowZero, biasing's: fewer steps
// for moments just past the moment set). Returns false where it cannot vouch for the result:
// c_0 <= 0 or not finite, no start that the recursion passes (positive definite, or past
// lambda_min only in its last step), or no convergence; a dense eigen-solve must then decide.
// Like any Newton iteration on 1/q_0, it can settle, rarely, just past a leading minor's
// lambda_min, where q_0 also vanishes: LooksLikeLambdaMinEigenvector(q) tells those apart. On
// success q = (C(c) - lambda I)^{-1} e_0 at the last iterate lambda, which points along
// lambda_min's eigenvector. q and c have the same size m+1.
inline constexpr double kToeplitzLambdaTolerance = 1e-12;  // relative to c_0
inline constexpr int kToeplitzLambdaMaxSteps = 64;  // Newton converges in ~5; bisection halves
// Gershgorin's bound on lambda_min is c_0 - 2 sum_j |c_j| (|c_j| as the square root of
// |c_j|^2, which SIMD lanes compute alike), less this much times c_0 to stay below it. Where
// |c_j|^2 overflows (|c_j| beyond ~1e154) the steps need that bound and decline; where it
// underflows (below ~1e-154) the value may not bound lambda_min, and the steps decline or
// start closer.
inline constexpr double kToeplitzGershgorinMargin = 1e-9;
enum class ToeplitzStart { kGershgorin, kSearchBelowZero };
[[nodiscard]] bool ToeplitzLambdaMin(std::span<const Complex> c, double* lambda_min,
                                     std::span<Complex> q,
                                     ToeplitzStart start = ToeplitzStart::kGershgorin);

// ToeplitzLambdaMin's step from an iterate that a step reached: from lambda, whose q_0 has Newton's
// step `newton` = q_0 / |q|^2 (|q|^2 = q_0'(lambda), `norm`), given the iterate before it,
// h = lambda - that iterate and rise = q_0(lambda) - q_0 there. Newton on 1 / q_0
// is exact where q_0 = a / (lambda_min - lambda), one pole; the other eigenvalues add to q_0 a
// part that varies slowly near lambda_min, and where that part is not small Newton creeps. The
// model q_0 = b + a / (mu - lambda), fitted to q_0 and q_0' at lambda and q_0 at the iterate
// before, takes that part into account: mu - lambda = rise h / (|q|^2 h - rise). (Rational
// models of q_0 of this kind are Mackens and Voss's, SIAM J. Matrix Anal. Appl. 18, 1997.)
// Between two iterates lies at most lambda_min, the model's one pole, so it holds on either
// side. Where it is not a finite step the way Newton's goes, Newton's. On a calibrated VGA frame
// of the mirrors scene (m = 4) the steps fell from 5.8 to 4.6 a pixel (docs/speed.md). The
// solve's and Pisarenko's lanes do the same operations (levinson_lanes.inc).
[[nodiscard]] inline double RationalStep(double newton, double h, double rise, double norm) {
  const double model = rise * h / (norm * h - rise);
  return model * newton > 0.0 && std::abs(model) <= std::numeric_limits<double>::max() ? model
                                                                                       : newton;
}

// Whether q, from ToeplitzLambdaMin, points along the eigenvector of a simple lambda_min: that
// eigenvector of a Hermitian Toeplitz matrix is conjugate-persymmetric, so |q_m| = |q_0| (to
// kToeplitzPersymmetryTolerance, relative). Not so at a degenerate lambda_min, or where the
// steps settled at a leading minor's lambda_min instead.
inline constexpr double kToeplitzPersymmetryTolerance = 1e-6;
[[nodiscard]] inline bool LooksLikeLambdaMinEigenvector(std::span<const Complex> q) {
  const double q0 = std::abs(q[0].real());
  return std::abs(std::norm(q.back()) / (q0 * q0) - 1.0) < 2.0 * kToeplitzPersymmetryTolerance;
}

// The inverse map: c from q = C^{-1}(c) e_0 (thesis alg. B.3, Landau 1987). Requires that q
// came from a positive-definite C(c), i.e. that its polynomial has no root in the closed unit
// disc (thesis lemma B.9); asserted in debug builds via q_0 > 0.
void InverseLevinson(std::span<const Complex> q, std::span<Complex> c);

// c_0 alone of that inverse map, equal to InverseLevinson's c[0] to the last bit: the recursion
// undone without InverseLevinson's triangular solve and its (m+1)^2 matrix, for the
// cumulative's per-pixel Init, which needs only c_0.
[[nodiscard]] double InverseLevinsonZeroth(std::span<const Complex> q);

}  // namespace transient

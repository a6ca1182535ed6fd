// The zeroth moment and biasing (thesis §8.3.3): making C(c) safely positive definite.
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

enum class BiasMode {
  kRaiseZeroth,   // raise c_0 (adds a uniform component; the thesis's default)
  kScaleMoments,  // scale c_1..c_m down (keeps the total brightness c_0)
};

// Smallest eigenvalue of the Hermitian Toeplitz matrix C(c) (dense eigen-solve, reference).
double SmallestEigenvalue(std::span<const Complex> c);

// Smallest eigenvalue of C(c) with its main diagonal set to zero; it is <= 0 because the
// matrix has zero trace, and 0 only when c_1 = ... = c_m = 0. Where c_0 > 0, it is
// lambda_min(C(c)) - c_0 by Newton's steps on Levinson's recursion (ToeplitzLambdaMin, to
// ~1e-12 c_0), unless those cannot vouch for it or end at a q that is not a simple lambda_min's
// eigenvector; else, and where c_0 <= 0, a dense eigen-solve.
double SmallestEigenvalueZeroDiagonal(std::span<const Complex> c);

// Estimate of an unmeasured c_0 such that lambda_min(C(c)) = epsilon * c_0:
// c_0 = -lambda_min(zero diagonal) / (1 - epsilon). Returns 0 when c_1..c_m are all zero
// (nothing to estimate from). Requires 0 < epsilon < 1.
double EstimateZerothMoment(std::span<const Complex> c, double epsilon);

// Biases c in place so that lambda_min(C(c)) >= epsilon * c_0, changing it minimally
// (thesis §8.3.3). Returns true when c was changed. Requires c_0 > 0 and 0 < epsilon < 1.
// kRaiseZeroth: c_0 += (epsilon*c_0 - lambda_min) / (1 - epsilon);
// kScaleMoments: c_j *= (1 - epsilon) * c_0 / -lambda_min(zero diagonal), j >= 1.
// Both reach lambda_min == epsilon * c_0 exactly (up to rounding). Unchanged where lambda_min
// is at least (epsilon - kBiasBoundSlack) c_0, so that moments that were just estimated or
// biased are not reported as changed by rounding. The optimized solve's lanes
// (optimized_solve_lanes.inc) repeat this arithmetic operation for operation.
inline constexpr double kBiasBoundSlack = 1e-10;  // relative to c_0
bool Bias(std::span<Complex> c, double epsilon, BiasMode mode);

}  // namespace transient

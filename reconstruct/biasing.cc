// Zeroth moment estimation and biasing (thesis §8.3.3).
#include "transient/reconstruct/biasing.h"

#include <algorithm>
#include <array>
#include <cassert>

#include "transient/reconstruct/levinson.h"

namespace transient {

double SmallestEigenvalue(std::span<const Complex> c) {
  return HermitianEigenvalues(MakeToeplitz(c))[0];
}

double SmallestEigenvalueZeroDiagonal(std::span<const Complex> c) {
  // Most pixels of a calibrated camera come here on every frame (issue 17: 91 % of a
  // calibrated 640x480 frame of the mirrors scene is biased; a sparse scene's moments lie on
  // the boundary of the moment set, and noise takes them past it). Newton's steps on
  // Levinson's recursion take a few O(m^2) recursions where the dense eigen-solve below took
  // most of the daemon's time (docs/speed.md). That solve stays for what they cannot vouch
  // for, and where their q is not a simple lambda_min's eigenvector (levinson.h).
  std::array<Complex, kMaxMoments> q;
  double lambda_min = 0.0;
  const std::span<Complex> q_span(q.data(), c.size());
  if (ToeplitzLambdaMin(c, &lambda_min, q_span, ToeplitzStart::kSearchBelowZero) &&
      LooksLikeLambdaMinEigenvector(q_span)) {
    return std::min(0.0, lambda_min - c[0].real());
  }
  ToeplitzMatrix t = MakeToeplitz(c);
  t.diagonal().setZero();
  return std::min(0.0, HermitianEigenvalues(t)[0]);
}

double EstimateZerothMoment(std::span<const Complex> c, double epsilon) {
  assert(epsilon > 0.0 && epsilon < 1.0);
  return -SmallestEigenvalueZeroDiagonal(c) / (1.0 - epsilon);
}

bool Bias(std::span<Complex> c, double epsilon, BiasMode mode) {
  assert(epsilon > 0.0 && epsilon < 1.0);
  const double c0 = c[0].real();
  assert(c0 > 0.0);
  // Adding delta to c_0 adds delta to every eigenvalue; scaling c_1..c_m by s scales the
  // eigenvalues of the zero-diagonal part by s. Either way lambda_min reaches epsilon * c_0.
  const double zero_diagonal_min = SmallestEigenvalueZeroDiagonal(c);
  const double lambda_min = c0 + zero_diagonal_min;
  if (lambda_min >= (epsilon - kBiasBoundSlack) * c0) return false;
  switch (mode) {
    case BiasMode::kRaiseZeroth:
      c[0] = Complex(-zero_diagonal_min / (1.0 - epsilon), 0.0);
      break;
    case BiasMode::kScaleMoments: {
      const double scale = (1.0 - epsilon) * c0 / -zero_diagonal_min;
      for (size_t j = 1; j < c.size(); ++j) c[j] *= scale;
      break;
    }
  }
  return true;
}

}  // namespace transient

// Zeroth moment estimation and biasing (thesis §8.3.3).
#include "transient/reconstruct/biasing.h"

#include <Eigen/Eigenvalues>
#include <cassert>

namespace transient {
namespace {

// Relative slack under which lambda_min counts as already at the bound, so that moments that
// were just estimated or biased are not reported as changed by rounding.
constexpr double kBoundSlack = 1e-10;

}  // namespace

double SmallestEigenvalue(std::span<const Complex> c) {
  const ToeplitzMatrix t = MakeToeplitz(c);
  Eigen::SelfAdjointEigenSolver<ToeplitzMatrix> solver(t, Eigen::EigenvaluesOnly);
  return solver.eigenvalues()[0];
}

double SmallestEigenvalueZeroDiagonal(std::span<const Complex> c) {
  ToeplitzMatrix t = MakeToeplitz(c);
  t.diagonal().setZero();
  Eigen::SelfAdjointEigenSolver<ToeplitzMatrix> solver(t, Eigen::EigenvaluesOnly);
  return std::min(0.0, solver.eigenvalues()[0]);
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
  if (lambda_min >= (epsilon - kBoundSlack) * c0) return false;
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

// Complex polynomial roots via the companion matrix, polished by Newton's method.
#include "transient/reconstruct/polynomial.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cassert>
#include <cmath>

namespace transient {
namespace {

constexpr double kNegligibleLeading = 1e-14;  // relative size below which a coefficient is 0
constexpr int kPolishSteps = 3;

// On the heap: with a maximum size on the stack, Eigen's solver default-constructs (zeroes)
// every complex of its 32 x 32 work matrices, ~80 KB a call, which cost more than the solve at
// the degrees used (3..16): the cumulative's profile showed 10 % in memset.
using CompanionMatrix = Eigen::Matrix<Complex, Eigen::Dynamic, Eigen::Dynamic>;

// p(x) and p'(x) together.
void EvaluateWithDerivative(std::span<const Complex> a, Complex x, Complex* value,
                            Complex* derivative) {
  Complex p = 0.0, dp = 0.0;
  for (size_t j = a.size(); j-- > 0;) {
    dp = dp * x + p;
    p = p * x + a[j];
  }
  *value = p;
  *derivative = dp;
}

}  // namespace

Complex EvaluatePolynomial(std::span<const Complex> coefficients, Complex x) {
  Complex p = 0.0;
  for (size_t j = coefficients.size(); j-- > 0;) p = p * x + coefficients[j];
  return p;
}

int PolynomialRoots(std::span<const Complex> coefficients, std::span<Complex> roots) {
  assert(!coefficients.empty() && coefficients.size() <= kMaxPolynomialDegree + 1);
  assert(roots.size() + 1 >= coefficients.size());
  double largest = 0.0;
  for (const Complex& a : coefficients) largest = std::max(largest, std::abs(a));
  int degree = static_cast<int>(coefficients.size()) - 1;
  while (degree > 0 && std::abs(coefficients[degree]) <= kNegligibleLeading * largest) --degree;
  if (degree == 0) return 0;
  const std::span<const Complex> a = coefficients.first(degree + 1);
  if (degree == 1) {
    roots[0] = -a[0] / a[1];
    return 1;
  }
  // Companion matrix of the monic polynomial x^n + sum_{j<n} (a_j/a_n) x^j.
  CompanionMatrix companion = CompanionMatrix::Zero(degree, degree);
  for (int i = 1; i < degree; ++i) companion(i, i - 1) = 1.0;
  for (int i = 0; i < degree; ++i) companion(i, degree - 1) = -a[i] / a[degree];
  Eigen::ComplexEigenSolver<CompanionMatrix> solver(companion, /*computeEigenvectors=*/false);
  for (int i = 0; i < degree; ++i) {
    Complex x = solver.eigenvalues()[i];
    Complex value, derivative;
    EvaluateWithDerivative(a, x, &value, &derivative);
    for (int step = 0; step < kPolishSteps; ++step) {
      if (derivative == Complex(0.0)) break;
      const Complex candidate = x - value / derivative;
      Complex candidate_value, candidate_derivative;
      EvaluateWithDerivative(a, candidate, &candidate_value, &candidate_derivative);
      if (!(std::abs(candidate_value) < std::abs(value))) break;  // converged to rounding
      x = candidate;
      value = candidate_value;
      derivative = candidate_derivative;
    }
    roots[i] = x;
  }
  return degree;
}

}  // namespace transient

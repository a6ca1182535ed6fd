// Toeplitz matrices and moments of Dirac measures (thesis def. 2.10, eq. 8.1).
#include "transient/reconstruct/moments.h"

#include <Eigen/Eigenvalues>
#include <cassert>
#include <cmath>

namespace transient {

ToeplitzMatrix MakeToeplitz(std::span<const Complex> c) {
  const int n = static_cast<int>(c.size());
  assert(n >= 1 && n <= kMaxMoments);
  ToeplitzMatrix t(n, n);
  for (int j = 0; j < n; ++j) {
    for (int k = 0; k < n; ++k) {
      const int d = j - k;
      if (d == 0) {
        t(j, k) = Complex(c[0].real(), 0.0);
      } else if (d > 0) {
        t(j, k) = c[d];
      } else {
        t(j, k) = std::conj(c[-d]);
      }
    }
  }
  return t;
}

RealSmallVector HermitianEigenvalues(const ToeplitzMatrix& t, ToeplitzMatrix* eigenvectors) {
  const Eigen::SelfAdjointEigenSolver<ToeplitzMatrix> solver(
      t, eigenvectors != nullptr ? Eigen::ComputeEigenvectors : Eigen::EigenvaluesOnly);
  if (eigenvectors != nullptr) *eigenvectors = solver.eigenvectors();
  return solver.eigenvalues();
}

void DiracMoments(std::span<const double> phases, std::span<const double> weights,
                  std::span<Complex> moments) {
  assert(phases.size() == weights.size());
  for (size_t j = 0; j < moments.size(); ++j) {
    Complex sum = 0.0;
    for (size_t l = 0; l < phases.size(); ++l) {
      sum += weights[l] * std::polar(1.0, static_cast<double>(j) * phases[l]);
    }
    moments[j] = sum;
  }
  moments[0] = Complex(moments[0].real(), 0.0);
}

}  // namespace transient

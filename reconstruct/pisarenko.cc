// Pisarenko estimate (thesis alg. 8.2 and its general case, §8.4.1).
#include "transient/reconstruct/pisarenko.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "transient/reconstruct/polynomial.h"

namespace transient {
namespace {

// For a simple lambda_min the eigenvector's polynomial has all its roots on the unit circle
// (Pisarenko 1973); a root farther away than this belongs to a degenerate (repeated)
// lambda_min, where the kernel holds spurious polynomials, and is not a return.
constexpr double kUnitCircleTolerance = 1e-3;
// Returns lighter than this share of the sparse mass are rounding artefacts of degenerate
// cases (a spurious root on the circle gets a weight of the order of machine epsilon).
constexpr double kNegligibleWeight = 1e-10;

using Residual = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 2 * kMaxMoments, 1>;
using Weights = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxOrder, 1>;
// The least-squares systems of the weights and of the Gauss-Newton steps share one type, so
// that one QR decomposition is compiled (Eigen's are the slowest templates to compile here).
using LeastSquaresMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 2 * kMaxMoments, 2 * kMaxOrder>;

// Real and imaginary parts of sum_l w_l exp(i j phi_l) - b_j, j = 0..m.
Residual MomentResidual(const Residual& b, int n, const std::array<double, kMaxOrder>& phases,
                        const Weights& w) {
  Residual residual = -b;
  for (int j = 0; j < b.size() / 2; ++j) {
    for (int l = 0; l < n; ++l) {
      const Complex x = w(l) * std::polar(1.0, j * phases[l]);
      residual(2 * j) += x.real();
      residual(2 * j + 1) += x.imag();
    }
  }
  return residual;
}

// The eigenvector's roots are only as accurate as u * ||C|| / (gap to the next eigenvalue);
// for close returns at large m that is ~1e-6. A few Gauss-Newton steps on the moment
// equations themselves (phases and weights together) bring them back to rounding level.
void PolishReturns(const Residual& b, int n, std::array<double, kMaxOrder>& phases, Weights& w) {
  constexpr int kSteps = 3;
  const int rows = static_cast<int>(b.size());
  Residual residual = MomentResidual(b, n, phases, w);
  for (int step = 0; step < kSteps; ++step) {
    LeastSquaresMatrix jacobian(rows, 2 * n);
    for (int j = 0; j < rows / 2; ++j) {
      for (int l = 0; l < n; ++l) {
        const Complex x = std::polar(1.0, j * phases[l]);
        const Complex dx = Complex(0.0, j * w(l)) * x;  // d/dphi_l of w_l exp(i j phi_l)
        jacobian(2 * j, l) = x.real();
        jacobian(2 * j + 1, l) = x.imag();
        jacobian(2 * j, n + l) = dx.real();
        jacobian(2 * j + 1, n + l) = dx.imag();
      }
    }
    const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 2 * kMaxOrder, 1> delta =
        jacobian.colPivHouseholderQr().solve(-residual);
    std::array<double, kMaxOrder> new_phases = phases;
    Weights new_w = w;
    for (int l = 0; l < n; ++l) {
      new_w(l) += delta(l);
      new_phases[l] = WrapPhase(phases[l] + delta(n + l));
    }
    const Residual new_residual = MomentResidual(b, n, new_phases, new_w);
    if (!(new_residual.squaredNorm() < residual.squaredNorm())) return;
    phases = new_phases;
    w = new_w;
    residual = new_residual;
  }
}

}  // namespace

bool Pisarenko(std::span<const Complex> c, PisarenkoEstimate* estimate) {
  const int size = static_cast<int>(c.size());
  const int m = size - 1;
  const double c0 = c[0].real();
  if (!(c0 > 0.0) || !std::isfinite(c0)) return false;
  for (const Complex& value : c) {
    if (!std::isfinite(value.real()) || !std::isfinite(value.imag())) return false;
  }
  ToeplitzMatrix eigenvectors;
  const double lambda_min = HermitianEigenvalues(MakeToeplitz(c), &eigenvectors)[0];
  estimate->uniform = lambda_min;
  estimate->count = 0;

  // Roots of sum_j conj(v_j) x^j for the eigenvector v of lambda_min (thesis alg. 8.2, step 2).
  std::array<Complex, kMaxMoments> coefficients;
  for (int j = 0; j < size; ++j) coefficients[j] = std::conj(eigenvectors(j, 0));
  std::array<Complex, kMaxOrder> roots;
  const int degree = PolynomialRoots(std::span<const Complex>(coefficients.data(), size), roots);
  std::array<double, kMaxOrder> phases;
  int n = 0;
  for (int l = 0; l < degree; ++l) {
    const double magnitude = std::abs(roots[l]);
    if (std::abs(magnitude - 1.0) > kUnitCircleTolerance) continue;
    phases[n++] = WrapPhase(std::arg(roots[l]));
  }
  if (n == 0) return true;  // all light is uniform

  // Real weights from the Vandermonde system against (c_0 - lambda_min, c_1, ..., c_m)
  // (thesis alg. 8.2, step 3), solved in the least-squares sense over all m+1 equations.
  LeastSquaresMatrix a(2 * size, n);
  Residual b(2 * size);
  for (int j = 0; j <= m; ++j) {
    const Complex target = (j == 0) ? Complex(c0 - lambda_min) : c[j];
    b(2 * j) = target.real();
    b(2 * j + 1) = target.imag();
    for (int l = 0; l < n; ++l) {
      const Complex x = std::polar(1.0, j * phases[l]);
      a(2 * j, l) = x.real();
      a(2 * j + 1, l) = x.imag();
    }
  }
  Weights w = a.colPivHouseholderQr().solve(b);
  PolishReturns(b, n, phases, w);

  std::array<int, kMaxOrder> order;
  std::iota(order.begin(), order.begin() + n, 0);
  std::sort(order.begin(), order.begin() + n, [&](int i, int j) { return phases[i] < phases[j]; });
  const double sparse_mass = std::max(c0 - lambda_min, 0.0);
  for (int i = 0; i < n; ++i) {
    const int l = order[i];
    if (!(w(l) > kNegligibleWeight * sparse_mass)) continue;
    estimate->phase[estimate->count] = phases[l];
    estimate->weight[estimate->count] = w(l);
    ++estimate->count;
  }
  return true;
}

}  // namespace transient

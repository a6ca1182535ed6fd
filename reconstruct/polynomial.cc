// Complex polynomial roots via the companion matrix polished by Newton's method, or by
// Aberth-Ehrlich's iteration.
#include "transient/reconstruct/polynomial.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

#include "kernels_internal.h"

namespace transient {
namespace {

constexpr double kNegligibleLeading = 1e-14;  // relative size below which a coefficient is 0
constexpr int kPolishSteps = 3;
// Aberth-Ehrlich's iteration stops after a sweep in which every correction was below this
// share of its root's modulus (the convergence is cubic for simple roots: they are then exact
// to rounding), and declines after this many sweeps.
constexpr double kAberthTolerance = 1e-14;
constexpr int kAberthSweeps = 50;

// On the heap: with a maximum size on the stack, Eigen's solver default-constructs (zeroes)
// every complex of its 32 x 32 work matrices, ~80 KB a call, which cost more than the solve at
// the degrees used (3..16): the cumulative's profile showed 10 % in memset.
using CompanionMatrix = Eigen::Matrix<Complex, Eigen::Dynamic, Eigen::Dynamic>;

// p(x) and p'(x) together, in std::complex arithmetic: the polish of the companion matrix's
// roots, whose rounding the reference kernels' results keep (the real-arithmetic Horner of
// polynomial.h serves the iterations written in real arithmetic).
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

// Aberth's start for degree n: unit vectors at angles 2 pi k / n + 0.4, k < n (off the real
// axis: real coefficients would otherwise keep the iterates in conjugate pairs), tabled once
// (a sine and a cosine per root and pixel were 2 % of `transient reconstruct`).
struct AberthStart {
  double cos[kMaxPolynomialDegree], sin[kMaxPolynomialDegree];
};
const std::array<AberthStart, kMaxPolynomialDegree + 1>& AberthStarts() {
  static const std::array<AberthStart, kMaxPolynomialDegree + 1> starts = [] {
    std::array<AberthStart, kMaxPolynomialDegree + 1> t{};
    for (int n = 1; n <= kMaxPolynomialDegree; ++n) {
      for (int k = 0; k < n; ++k) {
        const double angle = kTwoPi * k / n + 0.4;
        t[n].cos[k] = std::cos(angle);
        t[n].sin[k] = std::sin(angle);
      }
    }
    return t;
  }();
  return starts;
}

}  // namespace

Complex EvaluatePolynomial(std::span<const Complex> coefficients, Complex x) {
  Complex p = 0.0;
  for (size_t j = coefficients.size(); j-- > 0;) p = p * x + coefficients[j];
  return p;
}

bool AberthRoots(std::span<const Complex> a, std::span<Complex> roots) {
  const int n = static_cast<int>(a.size()) - 1;
  assert(n >= 1 && n <= kMaxPolynomialDegree && roots.size() >= static_cast<size_t>(n));
  // Real arithmetic throughout: std::complex's division calls __divdc3 and its abs hypot,
  // which cost more than the iteration at these degrees.
  double ar[kMaxPolynomialDegree + 1], ai[kMaxPolynomialDegree + 1];
  for (int j = 0; j <= n; ++j) {
    ar[j] = a[j].real();
    ai[j] = a[j].imag();
  }
  // Start on the circle of the roots' geometric mean modulus |a_0 / a_n|^(1/n) (AberthStarts).
  const double radius = std::pow(std::abs(a[0]) / std::abs(a[n]), 1.0 / n);
  if (!(radius > 0.0) || !std::isfinite(radius)) return false;
  const AberthStart& start = AberthStarts()[n];
  double zr[kMaxPolynomialDegree], zi[kMaxPolynomialDegree];
  for (int k = 0; k < n; ++k) {
    zr[k] = radius * start.cos[k];
    zi[k] = radius * start.sin[k];
  }
  const double tolerance_squared = kAberthTolerance * kAberthTolerance;
  for (int sweep = 0; sweep < kAberthSweeps; ++sweep) {
    bool converged = true;
    for (int k = 0; k < n; ++k) {
      const double xr = zr[k], xi = zi[k];
      const PolynomialAndDerivative v = EvaluateWithDerivative(ar, ai, n, xr, xi);
      const double pr = v.re, pi = v.im, dr = v.d_re, di = v.d_im;
      const double d2 = dr * dr + di * di;
      if (!(d2 > 0.0)) return false;  // p' = 0 at an iterate (or overflow, NaN)
      const double rr = (pr * dr + pi * di) / d2, ri = (pi * dr - pr * di) / d2;  // p / p'
      double sr = 0.0, si = 0.0;  // sum over the other iterates of 1 / (z_k - z_j)
      for (int j = 0; j < n; ++j) {
        if (j == k) continue;
        const double ur = xr - zr[j], ui = xi - zi[j];
        const double u2 = ur * ur + ui * ui;
        sr += ur / u2;
        si -= ui / u2;
      }
      // The correction (p / p') / (1 - (p / p') s).
      const double er = 1.0 - (rr * sr - ri * si), ei = -(rr * si + ri * sr);
      const double e2 = er * er + ei * ei;
      const double wr = (rr * er + ri * ei) / e2, wi = (ri * er - rr * ei) / e2;
      if (!std::isfinite(wr) || !std::isfinite(wi)) return false;  // iterates met, or overflow
      zr[k] = xr - wr;
      zi[k] = xi - wi;
      if (!(wr * wr + wi * wi <= tolerance_squared * (zr[k] * zr[k] + zi[k] * zi[k]))) {
        converged = false;
      }
    }
    if (converged) {
      // Vieta: the roots sum to -a_{n-1} / a_n. Two iterates that had settled on one root,
      // leaving another out, would miss it by the difference of the two.
      // (Moduli by square roots and the quotient in real arithmetic: std::abs calls hypot
      // and std::complex's division __divdc3.)
      Complex sum = 0.0;
      double size = 0.0;
      for (int k = 0; k < n; ++k) {
        roots[k] = Complex(zr[k], zi[k]);
        sum += roots[k];
        size += std::sqrt(std::norm(roots[k]));
      }
      const Complex miss = sum + internal::Divide(a[n - 1], a[n]);
      return std::sqrt(std::norm(miss)) <= 1e-8 * size;
    }
  }
  return false;
}

int PolynomialRoots(std::span<const Complex> coefficients, std::span<Complex> roots,
                    RootMethod method) {
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
  // Aberth's roots as they converged: its last sweep moved each by less than 1e-14 of its
  // modulus, and a Newton step after it would move a simple root by as little
  // (BM_CumulativeSlices at m = 3 ran 12 % faster without that polish).
  if (method == RootMethod::kAberth && AberthRoots(a, roots.first(degree))) return degree;
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

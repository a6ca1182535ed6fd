// Cumulative MESE distribution by partial fractions (thesis §8.4.4, eq. 8.9).
#include "transient/reconstruct/cumulative.h"

#include <cmath>

#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/polynomial.h"

namespace transient {

bool MeseCumulative::Init(std::span<const Complex> q) {
  const double q0 = q[0].real();
  std::array<Complex, kMaxOrder> roots;
  degree_ = MeseRoots(q, roots);
  const int n = degree_;
  // D(x) = q_0 x^n / (2 pi p(x) s(x)) on |x| = 1, with p(x) = sum_j conj(q_j) x^j (roots x_l
  // outside the circle) and s(x) = sum_j q_j x^{n-j} = x^n conj(p(1/conj x)) (roots
  // y_l = 1/conj(x_l) inside). Residues of the simple poles come from the derivatives.
  std::array<Complex, kMaxMoments> p, s;
  for (int j = 0; j <= n; ++j) {
    p[j] = std::conj(q[j]);
    s[n - j] = q[j];
  }
  const std::span<const Complex> p_span(p.data(), n + 1), s_span(s.data(), n + 1);
  std::array<Complex, kMaxMoments> p_derivative{}, s_derivative{};
  for (int j = 1; j <= n; ++j) {
    p_derivative[j - 1] = static_cast<double>(j) * p[j];
    s_derivative[j - 1] = static_cast<double>(j) * s[j];
  }
  const std::span<const Complex> dp_span(p_derivative.data(), n), ds_span(s_derivative.data(), n);
  const double factor = q0 / kTwoPi;
  Complex slope = 0.0;
  for (int l = 0; l < n; ++l) {
    const Complex x = roots[l];
    const Complex y = 1.0 / std::conj(x);
    const Complex outer_denominator = EvaluatePolynomial(dp_span, x) * EvaluatePolynomial(s_span, x);
    const Complex inner_denominator = EvaluatePolynomial(p_span, y) * EvaluatePolynomial(ds_span, y);
    if (std::abs(outer_denominator) == 0.0 || std::abs(inner_denominator) == 0.0) return false;
    const Complex outer_residue = factor * std::pow(x, n) / outer_denominator;
    const Complex inner_residue = factor * std::pow(y, n) / inner_denominator;
    // int_0^phi dt / (e^{it} - x) = -(1/x) (phi + i Log(1 - e^{i phi}/x)) + const, |x| > 1;
    // int_0^phi dt / (e^{it} - y) = -(i/y) Log(1 - y e^{-i phi}) + const,          |y| < 1.
    outer_pole_[l] = x;
    outer_coefficient_[l] = -outer_residue / x;
    inner_pole_[l] = y;
    inner_coefficient_[l] = -Complex(0.0, 1.0) * inner_residue / y;
    slope += outer_coefficient_[l];
  }
  // The linear term is D's mean c_0 / (2 pi). With degree 0, D = 1 / (2 pi q_0) is constant.
  slope_ = (n == 0) ? 1.0 / (kTwoPi * q0) : slope.real();
  for (int l = 0; l < n; ++l) {
    if (!std::isfinite(outer_coefficient_[l].real()) || !std::isfinite(inner_coefficient_[l].real()))
      return false;
  }
  return std::isfinite(slope_);
}

double MeseCumulative::operator()(double phase) const {
  const Complex unit = std::polar(1.0, phase);
  Complex sum = slope_ * phase;
  const Complex i(0.0, 1.0);
  for (int l = 0; l < degree_; ++l) {
    const Complex x = outer_pole_[l];
    const Complex y = inner_pole_[l];
    sum += outer_coefficient_[l] * i * (std::log(1.0 - unit / x) - std::log(1.0 - 1.0 / x));
    sum += inner_coefficient_[l] * (std::log(1.0 - y * std::conj(unit)) - std::log(1.0 - y));
  }
  return sum.real();
}

}  // namespace transient

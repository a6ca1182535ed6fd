// Cumulative MESE distribution by partial fractions (thesis §8.4.4, eq. 8.9).
#include "transient/reconstruct/cumulative.h"

#include <algorithm>
#include <cmath>

#include "kernels_internal.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/polynomial.h"
#include "transient/reconstruct/quadrature.h"

namespace transient {
namespace {

// Roots closer than this (relative) make the residues cancel catastrophically: a pair 1e-5
// apart already costs 14 % of c_0.
constexpr double kMinRootSeparation = 1e-3;
// The linear term must integrate to c_0 (from inverse Levinson) to this relative accuracy.
constexpr double kZerothMomentCheck = 1e-9;
// Absolute accuracy of the quadrature fallback, relative to c_0.
constexpr double kQuadratureTolerance = 1e-10;

// w = 1 - u / x for u = c + i s and 1/x = inverse_re + i inverse_im, in real arithmetic.
inline Complex ShiftedPole(double c, double s, double inverse_re, double inverse_im) {
  return {1.0 - (c * inverse_re - s * inverse_im), -(c * inverse_im + s * inverse_re)};
}
inline double LogNorm(Complex w) {
  return 0.5 * std::log(w.real() * w.real() + w.imag() * w.imag());
}
inline double ArgOfRight(Complex w) { return std::atan(w.imag() / w.real()); }  // Re w > 0

using internal::Divide;

}  // namespace

bool MeseCumulative::Init(std::span<const Complex> q, RootMethod method) {
  const double q0 = q[0].real();
  if (!(q0 > 0.0) || !std::isfinite(q0)) return false;
  size_ = static_cast<int>(q.size());
  log_at_zero_ready_ = false;
  for (int j = 0; j < size_; ++j) q_[j] = q[j];
  closed_form_ = false;
  c0_ = InverseLevinsonZeroth(q);

  std::array<Complex, kMaxOrder> roots;
  degree_ = MeseRoots(q, roots, method);
  const int n = degree_;
  for (int l = 0; l < n; ++l) {
    for (int k = 0; k < l; ++k) {
      // |x_l - x_k| >= kMinRootSeparation max(|x_l|, |x_k|), squared (std::norm, re^2 + im^2;
      // roots past 1e154, whose squares overflow, give residues that overflow below).
      const double scale = std::max(std::norm(roots[l]), std::norm(roots[k]));
      if (!(std::norm(roots[l] - roots[k]) >= kMinRootSeparation * kMinRootSeparation * scale)) {
        return true;
      }
    }
  }
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
  const std::span<const Complex> dp_span(p_derivative.data(), n);
  const std::span<const Complex> ds_span(s_derivative.data(), n);
  const double factor = q0 / kTwoPi;
  const Complex i(0.0, 1.0);
  Complex slope = 0.0;
  for (int l = 0; l < n; ++l) {
    const Complex x = roots[l];
    const Complex y = Divide(1.0, std::conj(x));
    const Complex outer_residue =
        Divide(factor * internal::Power(x, n),
               EvaluatePolynomial(dp_span, x) * EvaluatePolynomial(s_span, x));
    const Complex inner_residue =
        Divide(factor * internal::Power(y, n),
               EvaluatePolynomial(p_span, y) * EvaluatePolynomial(ds_span, y));
    // int_0^phi dt / (e^{it} - x) = -(1/x) (phi + i Log(1 - e^{i phi}/x)) + const, |x| > 1;
    // int_0^phi dt / (e^{it} - y) = -(i/y) Log(1 - y e^{-i phi}) + const,          |y| < 1.
    outer_pole_[l] = x;
    outer_coefficient_[l] = Divide(-outer_residue, x);
    inner_coefficient_[l] = Divide(-i * inner_residue, y);
    if (!IsFinite(outer_coefficient_[l]) || !IsFinite(inner_coefficient_[l])) return true;
    slope += outer_coefficient_[l];
  }
  // The linear term is D's mean c_0 / (2 pi). With degree 0, D = 1 / (2 pi q_0) is constant.
  slope_ = (n == 0) ? 1.0 / (kTwoPi * q0) : slope.real();
  closed_form_ = std::abs(slope_ * kTwoPi - c0_) <= kZerothMomentCheck * c0_;
  return true;
}

double MeseCumulative::operator()(double phase) const {
  if (!closed_form_) return Quadrature(phase);
  if (!log_at_zero_ready_) {
    for (int l = 0; l < degree_; ++l) log_at_zero_[l] = std::log(1.0 - 1.0 / outer_pole_[l]);
    log_at_zero_ready_ = true;
  }
  const Complex unit = std::polar(1.0, phase);
  Complex sum = slope_ * phase;
  const Complex i(0.0, 1.0);
  for (int l = 0; l < degree_; ++l) {
    // With y = 1/conj(x): 1 - y conj(u) = conj(1 - u/x), and both lie in the right half-plane
    // where the principal Log commutes with conjugation, so one log serves both poles.
    const Complex x = outer_pole_[l];
    const Complex log_outer = std::log(1.0 - unit / x) - log_at_zero_[l];
    sum += outer_coefficient_[l] * i * log_outer + inner_coefficient_[l] * std::conj(log_outer);
  }
  return sum.real();
}

CumulativeTerms MeseCumulative::Terms() const {
  // Per pole: w = 1 - u / x_l with Re w >= 1 - 1/|x_l| > 0, so arg w = atan(Im w / Re w)
  // (glibc's atan2 took a third of the time). The term's real part is A_l (log|w| - log|w_0|)
  // + B_l (arg w - arg w_0), w_0 = 1 - 1/x_l, with A_l = Re b_l - Im a_l and
  // B_l = Im b_l - Re a_l for a_l = outer_coefficient_ and b_l = inner_coefficient_ (the terms
  // of operator()). Whoever sums them takes w_0 with the same arithmetic as w at the other
  // phases (Evaluate below, the optimized kernel's lanes), so that F(0) = 0 exactly.
  CumulativeTerms t;
  t.degree = degree_;
  t.slope = slope_;
  for (int l = 0; l < degree_; ++l) {
    const Complex inverse = Divide(1.0, outer_pole_[l]);
    t.inverse_re[l] = inverse.real();
    t.inverse_im[l] = inverse.imag();
    t.weight_log[l] = inner_coefficient_[l].real() - outer_coefficient_[l].imag();
    t.weight_arg[l] = inner_coefficient_[l].imag() - outer_coefficient_[l].real();
  }
  return t;
}

void MeseCumulative::Evaluate(std::span<const double> phases, std::span<const double> cosines,
                              std::span<const double> sines, float* out, int64_t stride) const {
  const size_t count = phases.size();
  if (!closed_form_) {
    for (size_t n = 0; n < count; ++n) out[n * stride] = static_cast<float>((*this)(phases[n]));
    return;
  }
  const CumulativeTerms t = Terms();
  std::array<double, kMaxOrder> log_0, arg_0;  // at phase 0, by the arithmetic below
  for (int l = 0; l < t.degree; ++l) {
    const Complex w = ShiftedPole(1.0, 0.0, t.inverse_re[l], t.inverse_im[l]);
    log_0[l] = LogNorm(w);
    arg_0[l] = ArgOfRight(w);
  }
  for (size_t n = 0; n < count; ++n) {
    const double c = cosines[n], s = sines[n];
    double sum = t.slope * phases[n];
    for (int l = 0; l < t.degree; ++l) {
      const Complex w = ShiftedPole(c, s, t.inverse_re[l], t.inverse_im[l]);
      sum +=
          t.weight_log[l] * (LogNorm(w) - log_0[l]) + t.weight_arg[l] * (ArgOfRight(w) - arg_0[l]);
    }
    out[n * stride] = static_cast<float>(sum);
  }
}

double MeseCumulative::Quadrature(double phase) const {
  const std::span<const Complex> q(q_.data(), size_);
  return IntegrateAdaptive([&](double phi) { return MeseDensity(q, phi); }, 0.0, phase,
                           kQuadratureTolerance * c0_);
}

}  // namespace transient

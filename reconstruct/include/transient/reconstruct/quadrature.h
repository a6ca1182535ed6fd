// Adaptive Simpson quadrature: integrates the sharp peaks of MESE densities where a fixed
// grid would need ~1e6 samples (a root 1e-5 from the unit circle makes a peak that narrow).
#pragma once

#include <algorithm>
#include <cmath>

namespace transient {

namespace internal {

template <typename F>
double AdaptiveSimpsonStep(const F& f, double a, double b, double fa, double fm, double fb,
                           double whole, double tolerance, int depth) {
  const double m = 0.5 * (a + b);
  const double lm = 0.5 * (a + m), rm = 0.5 * (m + b);
  const double flm = f(lm), frm = f(rm);
  const double left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
  const double right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
  const double delta = left + right - whole;
  // Below ~100 ulps of the piece's own value the estimate is rounding noise: refining further
  // would only recurse to the depth limit.
  const double floor = 1e-14 * (std::abs(left) + std::abs(right));
  if (depth <= 0 || std::abs(delta) <= 15.0 * std::max(tolerance, floor)) {
    return left + right + delta / 15.0;
  }
  return AdaptiveSimpsonStep(f, a, m, fa, flm, fm, left, 0.5 * tolerance, depth - 1) +
         AdaptiveSimpsonStep(f, m, b, fm, frm, fb, right, 0.5 * tolerance, depth - 1);
}

}  // namespace internal

// Integral of f over [a, b] to an absolute error of about `tolerance`, splitting [a, b] into
// `pieces` equal parts first so that a peak cannot hide between the first samples. A piece
// stops refining at depth 30 or at a relative accuracy of 1e-14 of its own value, so the
// cost stays bounded whatever the tolerance.
template <typename F>
double IntegrateAdaptive(const F& f, double a, double b, double tolerance, int pieces = 64) {
  double sum = 0.0;
  const double h = (b - a) / pieces;
  for (int k = 0; k < pieces; ++k) {
    const double lo = a + k * h, hi = (k + 1 == pieces) ? b : a + (k + 1) * h;
    const double flo = f(lo), fmid = f(0.5 * (lo + hi)), fhi = f(hi);
    const double whole = (hi - lo) / 6.0 * (flo + 4.0 * fmid + fhi);
    sum += internal::AdaptiveSimpsonStep(f, lo, hi, flo, fmid, fhi, whole, tolerance / pieces, 30);
  }
  return sum;
}

}  // namespace transient

// Maximum entropy spectral estimate (thesis thm. 8.2, eq. 8.3-8.6).
#include "transient/reconstruct/mese.h"

#include <array>
#include <cassert>
#include <cmath>

#include "transient/reconstruct/polynomial.h"

namespace transient {

double MeseDensity(std::span<const Complex> q, double phase) {
  const Complex x = std::polar(1.0, phase);
  Complex p = 0.0;  // sum_j conj(q_j) x^j by Horner
  for (size_t j = q.size(); j-- > 0;) p = p * x + std::conj(q[j]);
  return q[0].real() / (kTwoPi * std::norm(p));
}

void MeseDensity(std::span<const Complex> q, std::span<const double> phases,
                 std::span<double> density) {
  assert(phases.size() == density.size());
  for (size_t n = 0; n < phases.size(); ++n) density[n] = MeseDensity(q, phases[n]);
}

void MeseDenominatorSeries(std::span<const Complex> q, std::span<Complex> a) {
  assert(a.size() == q.size());
  const size_t size = q.size();
  for (size_t k = 0; k < size; ++k) {
    Complex sum = 0.0;
    for (size_t j = 0; j + k < size; ++j) sum += std::conj(q[j + k]) * q[j];
    a[k] = sum;
  }
}

SeriesValue EvaluateDenominatorSeries(std::span<const Complex> a, double phase) {
  SeriesValue result{a[0].real(), 0.0, 0.0};
  // exp(i k phi) by repeated multiplication: one sin/cos per call; m <= 16 products keep the
  // rounding at a few ulps.
  const Complex unit = std::polar(1.0, phase);
  Complex power = 1.0;
  for (size_t k = 1; k < a.size(); ++k) {
    const double kd = static_cast<double>(k);
    power *= unit;
    const Complex term = a[k] * power;
    result.value += 2.0 * term.real();
    result.first -= 2.0 * kd * term.imag();
    result.second -= 2.0 * kd * kd * term.real();
  }
  return result;
}

int MeseRoots(std::span<const Complex> q, std::span<Complex> roots, RootMethod method) {
  std::array<Complex, kMaxMoments> coefficients;
  for (size_t j = 0; j < q.size(); ++j) coefficients[j] = std::conj(q[j]);
  return PolynomialRoots(std::span<const Complex>(coefficients.data(), q.size()), roots, method);
}

}  // namespace transient

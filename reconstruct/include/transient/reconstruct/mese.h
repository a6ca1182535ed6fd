// Maximum entropy spectral estimate (thesis thm. 8.2, §8.2.3) from q = C^{-1}(c) e_0.
//
// Convention: D(phi) = q_0 / (2*pi * |sum_j conj(q_j) exp(i*j*phi)|^2) per radian on
// [0, 2*pi); its trigonometric moments int exp(i*j*phi) D(phi) dphi equal c_j for j = 0..m.
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/polynomial.h"

namespace transient {

// D(phi) for one phase. q must come from Levinson() (q_0 > 0).
double MeseDensity(std::span<const Complex> q, double phase);

// D(phi_n) for many phases.
void MeseDensity(std::span<const Complex> q, std::span<const double> phases,
                 std::span<double> density);

// The denominator |sum_j conj(q_j) x^j|^2 on the unit circle as a real Fourier series
// a_0 + 2 Re sum_{k>=1} a_k exp(i*k*phi), a_k = sum_j conj(q_{j+k}) q_j (eq. 8.4). `a` has
// m+1 entries. Evaluating the series and its derivatives is what range refinement needs.
void MeseDenominatorSeries(std::span<const Complex> q, std::span<Complex> a);

// Value, first and second derivative (with respect to phi) of the denominator.
struct SeriesValue {
  double value, first, second;
};

// The series above at phi. Cheap once `a` is known, but near a sharp peak its relative error
// grows like u / eps^2 (the terms cancel to r_min ~ eps^2 a_0): good for locating a minimum
// (range.h's Newton steps), not for comparing the depths of minima, which range.h does with
// |p|^2 by Horner (EvaluatePolynomial).
SeriesValue EvaluateDenominatorSeries(std::span<const Complex> a, double phase);

// Roots of the denominator polynomial sum_j conj(q_j) x^j (eq. 8.5); all lie strictly outside
// the unit circle (lemma B.9). Returns their number (the degree, m unless q_m vanishes).
int MeseRoots(std::span<const Complex> q, std::span<Complex> roots,
              RootMethod method = RootMethod::kCompanionMatrix);

}  // namespace transient

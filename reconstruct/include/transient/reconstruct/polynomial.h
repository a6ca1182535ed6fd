// Roots of complex polynomials of degree <= 2 * kMaxOrder, for MESE and Pisarenko.
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

inline constexpr int kMaxPolynomialDegree = 2 * kMaxOrder;

// Evaluates sum_j coefficients[j] * x^j (Horner).
Complex EvaluatePolynomial(std::span<const Complex> coefficients, Complex x);

// Roots of sum_j coefficients[j] * x^j (ascending powers), as eigenvalues of the companion
// matrix, each polished by Newton steps. Leading coefficients that are negligible relative to
// the largest one (|a| <= 1e-14 * max |a|) are dropped, which lowers the degree; the number of
// roots written to `roots` (the degree) is returned. Returns 0 for a constant polynomial.
// `roots` must hold coefficients.size() - 1 entries.
int PolynomialRoots(std::span<const Complex> coefficients, std::span<Complex> roots);

}  // namespace transient

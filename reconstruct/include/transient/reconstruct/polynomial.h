// Roots of complex polynomials of degree <= 2 * kMaxOrder, for MESE and Pisarenko.
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

inline constexpr int kMaxPolynomialDegree = 2 * kMaxOrder;

// Evaluates sum_j coefficients[j] * x^j (Horner).
Complex EvaluatePolynomial(std::span<const Complex> coefficients, Complex x);

// How PolynomialRoots finds the roots it polishes.
enum class RootMethod {
  kCompanionMatrix,  // the eigenvalues of the companion matrix (Eigen's complex Schur)
  kAberth,           // AberthRoots, and the companion matrix where it declines
};

// Roots of sum_j coefficients[j] * x^j (ascending powers), as eigenvalues of the companion
// matrix polished by Newton steps, or by AberthRoots where `method` asks for it and it does not
// decline (its roots are final to rounding, with no polish). Leading coefficients that
// are negligible relative to the largest one (|a| <= 1e-14 * max |a|) are dropped, which lowers
// the degree; the number of roots written to `roots` (the degree) is returned. Returns 0 for a
// constant polynomial. `roots` must hold coefficients.size() - 1 entries.
int PolynomialRoots(std::span<const Complex> coefficients, std::span<Complex> roots,
                    RootMethod method = RootMethod::kCompanionMatrix);

// The n = a.size() - 1 roots of sum_j a_j x^j (a_n != 0) by Aberth-Ehrlich's simultaneous
// iteration (Aberth 1973), started on the circle of the roots' geometric mean modulus; stops
// once every correction is below 1e-14 of its root. Returns false, leaving `roots` unspecified,
// where it cannot vouch for them: no convergence within 50 sweeps (multiple or tightly
// clustered roots converge only linearly), a root at 0, p' = 0 at an iterate, a value that is
// not finite, or roots whose sum misses -a_{n-1} / a_n by more than 1e-8 of their moduli' sum
// (two iterates on one root). No general Schur decomposition (Eigen's); its sweeps use neither
// std::complex's division nor hypot.
bool AberthRoots(std::span<const Complex> a, std::span<Complex> roots);

}  // namespace transient

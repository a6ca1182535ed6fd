// Roots of complex polynomials of degree <= 2 * kMaxOrder, for MESE and Pisarenko.
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

inline constexpr int kMaxPolynomialDegree = 2 * kMaxOrder;

// Evaluates sum_j coefficients[j] * x^j (Horner).
Complex EvaluatePolynomial(std::span<const Complex> coefficients, Complex x);

// p(x) and p'(x) for p = sum_{j<=n} (re[j] + i im[j]) x^j at x = x_re + i x_im, by Horner in
// real arithmetic (std::complex's product and division cost more than the arithmetic at these
// degrees), for the Newton-type root iterations (AberthRoots, PisarenkoByLevinson).
struct PolynomialAndDerivative {
  double re, im;      // p(x)
  double d_re, d_im;  // p'(x)
};
inline PolynomialAndDerivative EvaluateWithDerivative(const double* re, const double* im, int n,
                                                      double x_re, double x_im) {
  double v_re = re[n], v_im = im[n], d_re = 0.0, d_im = 0.0;
  for (int j = n - 1; j >= 0; --j) {
    const double e_re = d_re * x_re - d_im * x_im + v_re;
    d_im = d_re * x_im + d_im * x_re + v_im;
    d_re = e_re;
    const double f_re = v_re * x_re - v_im * x_im + re[j];
    v_im = v_re * x_im + v_im * x_re + im[j];
    v_re = f_re;
  }
  return {v_re, v_im, d_re, d_im};
}

// How PolynomialRoots finds the roots.
enum class RootMethod {
  kCompanionMatrix,  // the eigenvalues of the companion matrix (Eigen's complex Schur)
  kAberth,           // AberthRoots, and the companion matrix where it declines
};

// Roots of sum_j coefficients[j] * x^j (ascending powers), as eigenvalues of the companion
// matrix polished by Newton steps, or by AberthRoots where `method` asks for it and it does not
// decline (its roots as they converged, with no polish). Leading coefficients that
// are negligible relative to the largest one (|a| <= 1e-14 * max |a|) are dropped, which lowers
// the degree; the number of roots written to `roots` (the degree) is returned. Returns 0 for a
// constant polynomial. `roots` must hold coefficients.size() - 1 entries.
int PolynomialRoots(std::span<const Complex> coefficients, std::span<Complex> roots,
                    RootMethod method = RootMethod::kCompanionMatrix);

// The n = a.size() - 1 roots of sum_j a_j x^j (a_n != 0) by Aberth-Ehrlich's simultaneous
// iteration (Aberth 1973), started on the circle of the roots' geometric mean modulus; stops
// after a sweep whose every correction was below 1e-14 of its root: simple roots are then exact
// to rounding (the convergence is cubic). A multiple root converges only linearly and is found
// to about the square root of the rounding, as the companion matrix finds it (the MESE
// cumulative declines roots that close itself). Returns false, leaving `roots` unspecified,
// where it cannot vouch for them: no convergence within 50 sweeps, a root at 0, p' = 0 at an
// iterate, a value that is not finite, or roots whose sum misses -a_{n-1} / a_n by more than
// 1e-8 of their moduli's sum (two iterates on one root). No general Schur decomposition
// (Eigen's); its sweeps use neither std::complex's division nor hypot.
bool AberthRoots(std::span<const Complex> a, std::span<Complex> roots);

}  // namespace transient

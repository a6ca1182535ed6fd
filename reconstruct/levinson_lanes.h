// Levinson's recursion (thesis alg. 8.1; LevinsonSteps of levinson.cc) in every SIMD lane, one
// pixel a lane, for the optimized solve (optimized_solve.cc) and Pisarenko
// (optimized_pisarenko.cc). Each lane runs the same IEEE operations in the same order as
// levinson.cc on std::complex (a complex product is (ac - bd, ad + bc)); the solve, compiled
// without contraction into fused multiply-adds, relies on that for results equal bit for bit.
// Include only from kernel sources, after kernels_simd.h's rules.
#pragma once

#include "kernels_simd.h"

namespace transient::simd {

// q = C^{-1} e_0 for the Hermitian Toeplitz C with first column (c0, c_1, ..., c_M), c_j =
// cr[j] + i ci[j] (cr[0] and ci[0] are not read: c0 takes c_0's place, as a shift of the
// diagonal). Returns the lanes where the recursion holds: c0 > 0 and finite, every reflection
// coefficient |d| < 1, q_0 finite (Levinson() and ShiftedLevinson() of levinson.h returning
// kPositiveDefinite). With kIndefiniteLast, the last step may also have a finite |d| > 1
// (ShiftedLevinson()'s kLastStepIndefinite: C is then past its smallest eigenvalue but short of
// the leading minor's); those lanes are also returned, and set in *indefinite.
template <int M, bool kIndefiniteLast = false>
__attribute__((always_inline)) inline Vm LevinsonLanes(Vd c0, const Vd* cr, const Vd* ci, Vd* qr,
                                                       Vd* qi, Vm* indefinite = nullptr) {
  const Vd zero = Splat(0.0), one = Splat(1.0);
  Vm ok = (c0 > zero) & Finite(c0);
  if (kIndefiniteLast) *indefinite = Vm{};
  qr[0] = one / c0;
  qi[0] = zero;
  for (int l = 1; l <= M; ++l) {
    Vd dr = zero, di = zero;  // d = sum_k q_k c_{l-k}
    for (int k = 0; k < l; ++k) {
      dr = dr + (qr[k] * cr[l - k] - qi[k] * ci[l - k]);
      di = di + (qr[k] * ci[l - k] + qi[k] * cr[l - k]);
    }
    const Vd norm = dr * dr + di * di;
    if (kIndefiniteLast && l == M) {
      const Vm past = (norm > one) & Finite(norm);
      ok &= (norm < one) | past;  // also false for NaN
      *indefinite = past;
    } else {
      ok &= norm < one;  // also false for NaN
    }
    const Vd scale = one / (one - norm);
    // q_k := scale (q_k - d conj(q_{l-k})) for k = 0..l, with q_l = 0 and conj(q_l) taken as 0
    // for k = 0 (the reversed vector of levinson.cc): in place, k and l - k together from
    // their old values (a copy of q each step cost more than the arithmetic at small m).
    for (int k = 0; 2 * k <= l; ++k) {
      const int h = l - k;
      const Vd old_kr = k < l ? qr[k] : zero, old_ki = k < l ? qi[k] : zero;
      const Vd old_hr = h < l ? qr[h] : zero, old_hi = h < l ? qi[h] : zero;
      // conj(q_{l-k}) for k and conj(q_{l-h}) = conj(q_k) for h, 0 at index 0.
      const Vd rkr = k == 0 ? zero : old_hr, rki = k == 0 ? zero : -old_hi;
      const Vd rhr = h == 0 ? zero : old_kr, rhi = h == 0 ? zero : -old_ki;
      qr[k] = scale * (old_kr - (dr * rkr - di * rki));
      qi[k] = scale * (old_ki - (dr * rki + di * rkr));
      if (h != k) {
        qr[h] = scale * (old_hr - (dr * rhr - di * rhi));
        qi[h] = scale * (old_hi - (dr * rhi + di * rhr));
      }
    }
  }
  qi[0] = zero;
  const Vm result = ok & Finite(qr[0]);
  if (kIndefiniteLast) *indefinite &= result;
  return result;
}

}  // namespace transient::simd

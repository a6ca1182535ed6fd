// Levinson's algorithm for q = C^{-1}(c) e_0 (thesis alg. 8.1) and its inverse (thesis alg. B.3).
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"

namespace transient {

// Solves C(c) q = e_0 for the Hermitian Toeplitz matrix C(c) of c = (c_0, ..., c_m) in O(m^2).
// Returns false, leaving q unspecified, when C(c) is not positive definite: c_0 <= 0, a
// reflection coefficient |d| >= 1, or a non-finite value. q and c have the same size m+1.
// Only Re c_0 is read. On success q_0 = e_0^* C^{-1} e_0 > 0 is real.
[[nodiscard]] bool Levinson(std::span<const Complex> c, std::span<Complex> q);

// The inverse map: c from q = C^{-1}(c) e_0 (thesis alg. B.3, Landau 1987). Requires that q
// came from a positive-definite C(c), i.e. that its polynomial has no root in the closed unit
// disc (thesis lemma B.9); asserted in debug builds via q_0 > 0.
void InverseLevinson(std::span<const Complex> q, std::span<Complex> c);

}  // namespace transient

// Trigonometric moment shadow mapping on normalised camera depth with two complex moments
// (thesis app. B.4; Peters & Klein 2015 supplement §7.4): depth becomes a phase on the circle,
// each pixel stores (1, e^{iφ}, e^{2iφ}) (filterable), and a query asks for a lower bound of
// the fraction of the footprint in front of a depth z̄_f.
//
// Conventions:
// - Normalised depth z̄ ∈ [-1, 1] (power_moments.h, DepthNormalisation) maps to the phase
//   φ = κ π z̄, κ = kTrigonometricPhaseScale < 1. The thesis (eq. B.4) takes κ = 1 with depths in
//   (-1, 1]; there z̄ = -1 and z̄ = 1 are the same point of the circle. Camera depth clamps to
//   both ends (DepthMoments), so we leave a gap of 2π(1 - κ) around φ = π, where the optimal
//   distributions of conj. B.7 put their extra support point. A bound over all distributions on
//   the circle is also a bound over those supported on [-κπ, κπ]: the gap costs sharpness, never
//   validity.
// - A moment vector t = (t_0, Re c_1, Im c_1, Re c_2, Im c_2) holds t_0 = Σ w_l and
//   c_j = Σ w_l e^{i j φ_l} (thesis eq. 8.1; the thesis's real a(z) of app. B.4.1 in its order).
//   t_0 is the coverage as in power_moments.h (0 = no valid depth); queries divide by it.
// - The Toeplitz matrix is C(c) = (c_{j-k}) (DESIGN.md, thesis def. 2.10). Biasing toward the
//   uniform distribution e_0 = (1, 0, 0) (thesis §B.4.2, the only bias invariant under cyclic
//   shifts): c' = (1 - α) c / t_0 + α e_0, so λ_min(C(c')) >= α.
// - The query returns a LOWER bound in [0, 1] of the fraction with phase in (-π, φ_f), i.e. of
//   Z(z̄ < z̄_f): the minimum over all distributions on (-π, π] with moments c' (thesis
//   Problem 3.1, solved in closed form for m = 2 via conj. B.7, alg. B.2, eq. B.5-B.7).
//   The bias can raise it by at most α above the truth: c' is the moment vector of
//   (1 - α) Z + α U with U uniform, whose fraction in front is <= Z(z̄ < z̄_f) + α.
// - Degenerate input never yields NaN: t_0 <= 0, a non-finite moment, a Toeplitz matrix that is
//   not positive definite after biasing (invalid moments), or a NaN z̄_f give 0 (nothing known,
//   nothing occludes). z̄_f is clamped to [-1/κ, 1/κ] (φ_f ∈ [-π, π]); φ_f = -π gives 0.
// Cost: the thesis calls the technique a dead end for shadow maps (slower than Hamburger 4MSM
// at 128 bits); the case φ_1 < φ_f <= φ_2 needs the critical points of a trigonometric
// polynomial of degree 2 (a quartic). It is here for comparisons and the pictures of issue 7.
#pragma once

#include <array>

#include "transient/reconstruct/power_moments.h"

namespace transient {

inline constexpr int kTrigonometricMomentCount = 5;  // t_0, Re c_1, Im c_1, Re c_2, Im c_2
using TrigonometricMoments = std::array<double, kTrigonometricMomentCount>;
using TrigonometricMomentsF = std::array<float, kTrigonometricMomentCount>;

// κ in φ = κ π z̄: near (z̄ = -1) and far (z̄ = 1) stay 0.2 π = 36° apart across φ = π. A trade:
// half the footprint at each end leaks 1.7% through the seam (tests), while κ = 0.75 compresses
// the phases so much that leaking next to every surface grew several times (measured).
inline constexpr double kTrigonometricPhaseScale = 0.9;

// φ = κ π z̄ (not clamped).
double TrigonometricPhase(double z);

// Biasing strength α toward e_0 (thesis §B.4.2): 6e-5 for 64-bit (16-bit channel) maps and
// 9e-7 for 128-bit (float) maps.
inline constexpr double kTrigonometricBias64 = 6e-5;
inline constexpr double kTrigonometricBias128 = 9e-7;

// t = (1, cos φ, sin φ, cos 2φ, sin 2φ) of one depth (metres), φ = κ π z̄. Depth handling as
// DepthMoments (power_moments.h): finite depths outside [near, far] are clamped (kClamped);
// NaN or infinite depth gives t = 0 and kInvalid. Requires a valid normalisation.
DepthSample DepthTrigonometricMoments(double depth_m, const DepthNormalisation& normalisation,
                                      TrigonometricMoments* moments);

// The lower bound of Z(z̄ < z̄_f) described above. Reference: double precision, Eigen's
// Cholesky solves with C(c'), roots of alg. B.2's quadratic and of the quartic of eq. B.7's
// critical points as companion-matrix eigenvalues (polynomial.h).
double TrigonometricOcclusionReference(const TrigonometricMoments& moments, double z_f,
                                       double alpha);
// Single precision throughout: LDLᴴ of C(c'), the same case decision, and the critical points
// of eq. B.7 by bracketing the derivative's sign changes on a grid of phases and refining each
// by bisection (no quartic formula, which loses all digits in float). Agrees with the reference
// to kTrigonometricFloatTolerance (tests) for α >= kTrigonometricBias64.
float TrigonometricOcclusion(const TrigonometricMomentsF& moments, float z_f, float alpha);

}  // namespace transient

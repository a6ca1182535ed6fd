// 64-bit (4 x uint16) storage of a four-power-moment depth texel: the optimized affine transform
// of thesis eq. 4.4 (linear, so still filterable after decoding) and the non-linear
// representation (y1, y2, v2, ξ4) of Peters 2017 (supplement 003 §1.1-1.4). b_0 is not stored:
// moments are divided by it before encoding and decode with b_0 = 1.
#pragma once

#include <array>
#include <cstdint>

#include "transient/reconstruct/power_moments.h"

namespace transient {

// Four 16-bit unsigned channels, each an integer code 0..65535 for a value in [0, 1].
struct QuantizedMoments64 {
  std::array<uint16_t, 4> channel{};
};

// ---- optimized affine quantization (thesis §4.1.4, eq. 4.4) ----------------------------------
// Θ(b) = (1.5 b1 - 2 b3 + 0.5,  4 b2 - 4 b4,  (√3/2) b1 - (2√3/9) b3 + 0.5,  0.5 b2 + 0.5 b4)
// maps conv b([-1, 1]) into [0, 1]^4 (odd and even moments transformed separately). Decode with
// kQuantized16MomentBias (b* = (1, 0, 0.628, 0, 0.628), alpha = 6e-5).

// Θ(b / b_0) in double, unclamped (a valid moment vector gives values in [0, 1]).
std::array<double, 4> OptimizedTransform(const PowerMoments& moments);
// Inverse of Θ: moments with b_0 = 1.
PowerMoments InverseOptimizedTransform(const std::array<double, 4>& theta);

// Rounds Θ(b / b_0), clamped to [0, 1], to 16 bits. Returns false when b_0 is not positive or a
// moment is not finite; `out` then encodes a single surface at the far plane (z̄ = 1), which
// occludes nothing nearer than `far`, and the caller should flag the pixel.
bool EncodeOptimized64(const PowerMoments& moments, QuantizedMoments64* out);
PowerMoments DecodeOptimized64(const QuantizedMoments64& quantized);
// Single-precision decode, the form a renderer uses.
PowerMomentsF DecodeOptimized64F(const QuantizedMoments64& quantized);
// OcclusionFraction for a 64-bit optimized texel: float decode + Hamburger 4MSM with
// kQuantized16MomentBias. Same meaning of inputs and result as OcclusionFraction.
float OcclusionFractionOptimized64(const QuantizedMoments64& quantized, float z_f);

// ---- non-linear representation (supplement 003) ----------------------------------------------
// S = (1 - v2) δ_{y1} + v2 δ_{y2} is the two-point distribution reproducing b_0..b_3 (the
// two-point Gauss quadrature of the depth distribution; y1, y2 are the roots of
// (b2 - b1²) z² + (b1 b2 - b3) z + (b1 b3 - b2²)), and ξ4 = b4 - E_S(z⁴) = b4 - b2² -
// (b3 - b1 b2)² / (b2 - b1²) >= 0 is the Schur complement of the Hankel matrix. For depths in
// [-1, 1]: y1, y2 ∈ [-1, 1] (prop. 2), ξ4 <= 0.25 (prop. 3, sharp), and ξ4 scales as
// ξ4' = c⁴ ξ4 under z -> c z + d (prop. 4). y1, y2 also split the queries into the three cases
// of alg. 4.2 (prop. 1). Decoding always gives a valid moment vector (positive semi-definite
// Hankel matrix), so quantization error moves depths but never invalidates the moments.
struct NonLinearMoments {
  double y1 = 0.0;   // lower support point of S
  double y2 = 0.0;   // upper support point, y2 >= y1
  double v2 = 0.0;   // weight of S at y2, in [0, 1]
  double xi4 = 0.0;  // >= 0
};

// Exact representation of b / b_0 for a distribution on the real line (no range clamping, so
// the scaling property can be checked on rescaled depths). A variance b2 - b1² below
// kMinNonLinearVariance (a single surface up to rounding) gives y1 = y2 = b1, v2 = 0.
// Returns false (and zeros) when b_0 is not positive or a moment is not finite.
inline constexpr double kMinNonLinearVariance = 1e-14;
bool ToNonLinear(const PowerMoments& moments, NonLinearMoments* out);
// b_j = (1 - v2) y1^j + v2 y2^j for j <= 3, b4 = that + ξ4; b_0 = 1.
PowerMoments FromNonLinear(const NonLinearMoments& representation);

// 16-bit codes: y1, y2 as (y + 1)/2 (clamped to [-1, 1]), v2 as is, ξ4 as sqrt(4 ξ4) (clamped to
// [0, 0.25]; the square root, our choice where supplement 003 fixes none, spends more codes on
// the small ξ4 of pixels with one or two surfaces). Invalid input as for EncodeOptimized64.
bool EncodeNonLinear64(const PowerMoments& moments, QuantizedMoments64* out);
NonLinearMoments DecodeNonLinear64(const QuantizedMoments64& quantized);

}  // namespace transient

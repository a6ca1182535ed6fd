// Power moments of normalised camera depth and the occlusion bounds that moment shadow mapping
// computes from them (thesis ch. 4, app. C.1-C.2; Peters & Klein 2015, supplement §7).
//
// Conventions used throughout this header:
// - Depth z (metres, the optical-frame Z of DESIGN.md) is mapped affinely to normalised depth
//   z̄ = 2 (z - near) / (far - near) - 1 in [-1, 1]. Thesis §4.1.5 shows that [-1, 1] keeps the
//   most single-precision information (conv b([-1,1]) is 1024 times the volume of conv b([0,1])).
// - A moment vector b = (b_0, ..., b_4) holds b_j = Σ_l w_l z̄_l^j. b_0 is the coverage: 1 for
//   one valid depth (or a normalised weighted set), 0 for an invalid pixel, and the fraction of
//   valid footprint after a linear filter. The occlusion functions divide by b_0, so filtered
//   maps can be queried directly.
// - Every occlusion function returns a number in [0, 1]: a LOWER bound of the fraction of the
//   pixel's footprint (the depth distribution Z that b summarises) lying strictly in front of the
//   query depth z̄_f, i.e. of Z(z̄ < z̄_f). 0 means "nothing known to be in front: fully visible",
//   1 "fully occluded". It is a lower bound over all distributions with moments b (the
//   Markov-Krein / Chebyshev bound, thesis thm. 4.1), computed from biased moments
//   b' = (1 - α) b / b_0 + α b* (thesis eq. 4.2). The bias can only RAISE the bound by at most α
//   above the exact lower bound of b (thesis §4.1.3): result <= Z(z̄ < z̄_f) + α.
//   In the thesis's words the value is the "shadow intensity".
// - Degenerate input never yields NaN: b_0 <= 0 or any non-finite moment or a NaN z̄_f gives 0
//   (nothing known, nothing occludes); z̄_f is clamped to [-kMaxQueryDepth, kMaxQueryDepth]
//   first, which keeps the result a lower bound because the bound is non-decreasing in z̄_f.
// Each technique has a double-precision reference (a plain implementation of the thesis's
// algorithm with dense solves) and a single-precision robust form (float arithmetic throughout,
// the form a renderer evaluates per fragment); tests check that they agree.
#pragma once

#include <array>
#include <span>

#include "absl/status/status.h"

namespace transient {

inline constexpr int kPowerMomentCount = 5;  // b_0..b_4: four power moments plus coverage
using PowerMoments = std::array<double, kPowerMomentCount>;
using PowerMomentsF = std::array<float, kPowerMomentCount>;

// The camera-depth range mapped to [-1, 1]. Choose it as tight as the scene allows: the bias
// costs relatively more light leaking the wider the range (thesis §4.1.5, last paragraph).
struct DepthNormalisation {
  double near_m = 0.0;  // metres, maps to z̄ = -1
  double far_m = 1.0;   // metres, maps to z̄ = +1

  // OK when both are finite and near_m < far_m.
  absl::Status Validate() const;

  // z̄ = 2 (depth_m - near_m) / (far_m - near_m) - 1, not clamped.
  double Normalise(double depth_m) const {
    return 2.0 * (depth_m - near_m) / (far_m - near_m) - 1.0;
  }
  double Denormalise(double z) const { return near_m + 0.5 * (z + 1.0) * (far_m - near_m); }
};

// What happened to the depths that went into a moment vector, most severe last.
enum class DepthSample {
  kValid,    // every depth was finite and inside [near, far]
  kClamped,  // some finite depth lay outside [near, far] and was clamped to the nearer end
  kDropped,  // some entries were dropped (non-finite depth, weight not finite and > 0)
  kInvalid,  // nothing usable: the moments are all zero (b_0 = 0)
};

// b = (1, z̄, z̄², z̄³, z̄⁴) for one depth (metres). A finite depth outside [near, far] is
// clamped to the range (a surface nearer than `near` still occludes everything behind it) and
// reported as kClamped; NaN or infinite depth (REP 118's invalid) gives b = 0 and kInvalid.
// Callers holding 16UC1 depth must map its 0 (invalid) to NaN first. Requires a valid
// normalisation (checked once by Validate where it enters the system).
DepthSample DepthMoments(double depth_m, const DepthNormalisation& normalisation,
                         PowerMoments* moments);

// Moments of a weighted set of depths (e.g. a pixel's Pisarenko returns converted to depth,
// weighted by their weights), normalised so that the used weights sum to 1: b_0 = 1, or b = 0
// with kInvalid when no entry is usable. Entries with a non-finite depth or a weight that is
// not finite and positive are dropped (kDropped); out-of-range depths are clamped (kClamped).
// Requires depths_m.size() == weights.size().
DepthSample WeightedDepthMoments(std::span<const double> depths_m,
                                 std::span<const double> weights,
                                 const DepthNormalisation& normalisation, PowerMoments* moments);

// Biasing of thesis eq. 4.2: b' = (1 - alpha) b + alpha b*, b* = (1, 0, b_star_even, 0,
// b_star_even), which lies in conv b([-1, 1]) for 0 <= b_star_even <= 1.
struct MomentBias {
  double alpha = 0.0;
  double b_star_even = 0.375;
};

// For moments held in single precision (128-bit maps, float filtering): b* of eq. 4.3.
// The thesis reports alpha = 3e-7 as enough on its GPU pipeline (§4.1.3). Measured here on
// moments rounded once to float (1..8 surfaces, many at the ends of the range, pairs 1e-4
// apart), the float path departs from the double reference by up to 1 at alpha = 3e-7,
// 0.016 at 1e-6 and 0.002 at 1e-5 (queries >= 0.01 from every surface). We take 1e-5: about
// 30 times the smallest working value, room for the few ulps a float filter adds.
inline constexpr MomentBias kFloatMomentBias{1e-5, 0.375};
// For moments decoded from 16-bit optimized quantization (eq. 4.4): the thesis's adapted
// b* = (1, 0, 0.628, 0, 0.628) and alpha = 6e-5 (§4.1.4).
inline constexpr MomentBias kQuantized16MomentBias{6e-5, 0.628};

// Queries are clamped to this magnitude (normalised units) before evaluation.
inline constexpr double kMaxQueryDepth = 4.0;

// Hamburger 4MSM (thesis alg. 4.1 for m = 4): the sharp lower bound of Z(z̄ < z̄_f) over all
// distributions on the real line with moments b'. Reference: Cholesky solve of the Hankel
// system, quadratic formula, Vandermonde solve for the weights (Eigen, double).
double Hamburger4OcclusionReference(const PowerMoments& moments, double z_f,
                                    const MomentBias& bias);
// Robust single-precision form of thesis alg. 4.2: LDLᵀ of the Hankel matrix, and a case
// decision from the sign of the quadratic's leading coefficient and its slope at z̄_f (no
// division by a vanishing leading coefficient, so the thm. 4.1 failure points z̄_f = y_1, y_2
// of supplement 003 prop. 1 are continuous limits instead of NaN).
float Hamburger4Occlusion(const PowerMomentsF& moments, float z_f, const MomentBias& bias);

// Hausdorff 4MSM (supplement 000 alg. 4, adapted to [-1, 1] as in thesis app. C.2): the sharp
// lower bound over distributions supported on [-1, 1]. Equals Hamburger's bound when its
// three-point solution lies inside [-1, 1], otherwise uses the four-point solution with support
// at -1, 1, z̄_f and one free point. Hence 0 for z̄_f <= -1 and 1 for z̄_f > 1.
double Hausdorff4OcclusionReference(const PowerMoments& moments, double z_f,
                                    const MomentBias& bias);
float Hausdorff4Occlusion(const PowerMomentsF& moments, float z_f, const MomentBias& bias);

// Variance shadow maps (the assignment's formula), as a lower bound of the same quantity:
// μ = b'_1, σ² = b'_2 - b'_1², and for z̄_f > μ
//   result = 1 - σ² / (σ² + (z̄_f - μ)²),
// where σ² / (σ² + (z̄_f - μ)²) is the one-sided Chebyshev (Cantelli) UPPER bound of the lit
// fraction Z(z̄ >= z̄_f); for z̄_f <= μ the result is 0. The same bias is applied, so that VSM and
// 4MSM answer from the same moments (then Hamburger >= VSM: more moments, tighter bound).
double VarianceOcclusionReference(const PowerMoments& moments, double z_f,
                                  const MomentBias& bias);
float VarianceOcclusion(const PowerMomentsF& moments, float z_f, const MomentBias& bias);

// The function for renderer authors. `moments` is a texel of a (filtered) 128-bit moment depth
// map: b_0 = coverage (0 for no valid depth), b_1..b_4 = coverage-weighted powers of normalised
// depth. `z_f` is the virtual fragment's depth normalised with the map's DepthNormalisation
// (z̄_f = 2 (z_f - near) / (far - near) - 1). Returns the fraction of the texel's footprint that
// the real scene covers in front of the fragment, as a lower bound in [0, 1]: multiply the
// fragment's visibility by (1 - result). 0 = fully visible, 1 = fully occluded; a texel without
// valid depth gives 0. Hamburger 4MSM in single precision with kFloatMomentBias.
float OcclusionFraction(const PowerMomentsF& moments, float z_f);

// Many queries at once, for renderers that test a tile of fragments (or a whole image) against
// a moment depth map on the CPU: out[i] = Hamburger4Occlusion(moments[i], z_f[i], bias), i.e.
// OcclusionFraction(moments[i], z_f[i]) with the default bias, and the kOptimized64 answer with
// kQuantized16MomentBias (decode the texels with DecodeOptimized64F first). Same inputs, same
// results (bit for bit: the same float operations in the same order), same treatment of
// degenerate input (0, never NaN); about 20 times the scalar rate. Thesis alg. 4.2 in select
// form: every query computes all three cases of the scalar function's branches on the sign of
// the quadratic's leading coefficient and slope, and keeps one, eight queries per AVX2
// instruction (chosen at run time; other CPUs run the scalar function). Texels are read as they
// are stored, one PowerMomentsF each. Single-threaded: give each renderer thread its own range.
// `out` must not overlap the inputs. Requires moments.size() == z_f.size() == out.size().
void OcclusionFractions(std::span<const PowerMomentsF> moments, std::span<const float> z_f,
                        std::span<float> out, const MomentBias& bias = kFloatMomentBias);

}  // namespace transient

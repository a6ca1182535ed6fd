// Power moments of normalised depth and the moment shadow mapping bounds (thesis ch. 4,
// app. C; Peters & Klein 2015 supplement §7). See power_moments.h for the conventions.
#include "transient/reconstruct/power_moments.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>
#include <immintrin.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>

#include "absl/strings/str_cat.h"

namespace transient {
namespace {

// Biased moments with b_0 = 1, or false when the input carries no usable information.
template <typename Real>
bool BiasedMoments(const std::array<Real, kPowerMomentCount>& moments, const MomentBias& bias,
                   std::array<Real, kPowerMomentCount>* biased) {
  for (const Real m : moments) {
    if (!std::isfinite(m)) return false;
  }
  if (!(moments[0] > Real(0))) return false;
  const Real alpha = static_cast<Real>(bias.alpha);
  const Real keep = (Real(1) - alpha) / moments[0];
  const Real even = alpha * static_cast<Real>(bias.b_star_even);
  (*biased)[0] = Real(1);
  (*biased)[1] = keep * moments[1];
  (*biased)[2] = keep * moments[2] + even;
  (*biased)[3] = keep * moments[3];
  (*biased)[4] = keep * moments[4] + even;
  return true;
}

// NaN gives false; otherwise clamps to [-kMaxQueryDepth, kMaxQueryDepth].
template <typename Real>
bool ClampQuery(Real* z_f) {
  if (std::isnan(*z_f)) return false;
  const Real limit = static_cast<Real>(kMaxQueryDepth);
  *z_f = std::clamp(*z_f, -limit, limit);
  return true;
}

template <typename Real>
Real Saturate(Real value) {
  return value >= Real(0) ? std::min(value, Real(1)) : Real(0);  // NaN -> 0
}

// ---- double-precision references -------------------------------------------------------------

// Result of the three-point (canonical) solution of thesis alg. 4.1 for m = 4.
struct ThreePointSolution {
  bool ok = false;  // false: B not positive definite or q_2 = 0 (thm. 4.1's failure cases)
  double z1 = 0.0, z2 = 0.0;  // the two further support points, z1 <= z2
  double occlusion = 0.0;     // sum of the weights at support points < z_f
};

ThreePointSolution HamburgerThreePoint(const PowerMoments& b, double z_f) {
  ThreePointSolution result;
  Eigen::Matrix3d hankel;
  hankel << b[0], b[1], b[2], b[1], b[2], b[3], b[2], b[3], b[4];
  const Eigen::LLT<Eigen::Matrix3d> cholesky(hankel);
  if (cholesky.info() != Eigen::Success) return result;
  const Eigen::Vector3d q = cholesky.solve(Eigen::Vector3d(1.0, z_f, z_f * z_f));
  if (q[2] == 0.0) return result;
  // Roots of q_2 z² + q_1 z + q_0: real and distinct from z_f in exact arithmetic.
  const double half_p = 0.5 * q[1] / q[2];
  const double root = std::sqrt(std::max(half_p * half_p - q[0] / q[2], 0.0));
  result.z1 = -half_p - root;
  result.z2 = -half_p + root;
  Eigen::Matrix3d vandermonde;
  vandermonde << 1.0, 1.0, 1.0, z_f, result.z1, result.z2, z_f * z_f, result.z1 * result.z1,
      result.z2 * result.z2;
  const Eigen::Vector3d w =
      vandermonde.fullPivLu().solve(Eigen::Vector3d(b[0], b[1], b[2]));
  if (!w.allFinite()) return result;
  result.occlusion = (result.z1 < z_f ? w[1] : 0.0) + (result.z2 < z_f ? w[2] : 0.0);
  result.ok = true;
  return result;
}

// ---- single precision ------------------------------------------------------------------------

// LDLᵀ factorisation of the 3x3 Hankel matrix of biased moments (b_0 = 1): L = [1 0 0; b1 1 0;
// b2 l21 1], D = diag(1, d1, d2). d1 is the variance and d2 the Schur complement ξ_4 of
// supplement 003; both are floored at a tiny positive value so that rounding in invalid input
// cannot produce a division by zero or a negative pivot.
struct HankelLdlt {
  float b1, b2, l21, d1, d2;
};

HankelLdlt FactorHankel(const PowerMomentsF& b) {
  constexpr float kMinPivot = 1e-30f;
  HankelLdlt f;
  f.b1 = b[1];
  f.b2 = b[2];
  f.d1 = std::max(std::fma(-b[1], b[1], b[2]), kMinPivot);
  const float t = std::fma(-b[1], b[2], b[3]);
  f.l21 = t / f.d1;
  f.d2 = std::max(std::fma(-f.l21, t, std::fma(-b[2], b[2], b[4])), kMinPivot);
  return f;
}

// Quantities of the quadratic Q(z) = b̂(z)ᵀ B⁻¹ b̂(z_f) = q_2 z² + q_1 z + q_0, all taken
// relative to z_f: Q(z_f) = 1/w_0 > 0 (supplement 000 prop. 10) and the slope Q'(z_f).
struct QuadraticAtQuery {
  float q2;     // leading coefficient
  float value;  // Q(z_f) = 1 + y1²/d1 + y2²/d2, a sum of positive terms: no cancellation
  float slope;  // Q'(z_f) = 2 q2 z_f + q1
};

QuadraticAtQuery SolveAtQuery(const HankelLdlt& f, float z_f) {
  // Forward substitution L y = (1, z_f, z_f²).
  const float y1 = z_f - f.b1;
  const float y2 = std::fma(-f.l21, y1, std::fma(z_f, z_f, -f.b2));
  const float s1 = y1 / f.d1;
  const float s2 = y2 / f.d2;
  QuadraticAtQuery q;
  q.q2 = s2;                            // back substitution: q2 = y2/d2
  const float q1 = s1 - f.l21 * s2;     // q1 = y1/d1 - l21 q2
  q.value = std::fma(y2, s2, std::fma(y1, s1, 1.0f));
  q.slope = std::fma(2.0f * q.q2, z_f, q1);
  return q;
}

// Roots of Q as offsets u from z_f: q2 u² + slope u + value = 0. Stable form (no subtraction of
// nearly equal numbers); a vanishing q2 sends one root to +-infinity.
void RootOffsets(const QuadraticAtQuery& q, float* u_low, float* u_high) {
  const float discriminant = std::max(std::fma(q.slope, q.slope, -4.0f * q.q2 * q.value), 0.0f);
  const float t = -0.5f * (q.slope + std::copysign(std::sqrt(discriminant), q.slope));
  const float a = t / q.q2;
  const float c = q.value / t;
  *u_low = std::min(a, c);
  *u_high = std::max(a, c);
}

// w = 1 / (b̂(z)ᵀ B⁻¹ b̂(z)): the weight a canonical representation puts at its support point z
// (supplement 000 prop. 10). Far-away z gives a weight near 0.
float SupportWeight(const HankelLdlt& f, float z) {
  const float e1 = z - f.b1;
  const float e2 = std::fma(-f.l21, e1, std::fma(z, z, -f.b2));
  const float form = std::fma(e2, e2 / f.d2, std::fma(e1, e1 / f.d1, 1.0f));
  return 1.0f / form;
}

// Hamburger 4MSM on biased moments, z_f already clamped.
float HamburgerBiased(const PowerMomentsF& b, float z_f) {
  const HankelLdlt f = FactorHankel(b);
  const QuadraticAtQuery q = SolveAtQuery(f, z_f);
  // Q(z) = q2 (z - z1)(z - z2) and Q(z_f) > 0: for q2 > 0, z_f lies outside [z1, z2] (left of
  // both when Q falls at z_f, right of both otherwise); for q2 < 0 it lies between them.
  if (q.q2 > 0.0f) {
    if (q.slope <= 0.0f) return 0.0f;  // z_f <= z1: nothing in front
    return Saturate(1.0f - 1.0f / q.value);  // z_f > z2: everything but w_0
  }
  if (!(q.q2 < 0.0f)) return 0.0f;  // q2 == 0: thm. 4.1's failure point; 0 is a safe bound
  // z1 < z_f <= z2: the result is w_1, the weight at the root below z_f.
  float u_low, u_high;
  RootOffsets(q, &u_low, &u_high);
  constexpr float kFarAway = 1e4f;  // a support point this far from [-1, 1] has weight ~ 1e-8
  if (!(u_low > -kFarAway)) return 0.0f;
  return Saturate(SupportWeight(f, z_f + u_low));
}

// Four-point solution of the Hausdorff problem with support {-1, z, z_f, 1} (supplement 000
// prop. 11 with endpoints -1 and 1; thesis app. C.2). The polynomial (t² - 1)(t - z_f)(t - z)
// vanishes on the support, so its expectation does: that fixes z linearly. Weights at -1 and z
// are expectations of their Lagrange polynomials on the four nodes, computed from b_0..b_3.
template <typename Real>
Real HausdorffFourPoint(const std::array<Real, kPowerMomentCount>& b, Real z_f) {
  const Real numerator = b[4] - b[2] + z_f * (b[1] - b[3]);    // E[(t²-1)(t-z_f) t]
  const Real denominator = b[3] - b[1] + z_f * (Real(1) - b[2]);  // E[(t²-1)(t-z_f)]
  const Real z = numerator / denominator;
  // E[(t - z)(t - z_f)(t - 1)] / ((-1 - z)(-1 - z_f)(-2))
  const Real s = z + z_f + Real(1);
  const Real p = z * z_f + z + z_f;
  const Real e_low = b[3] - s * b[2] + p * b[1] - z * z_f;
  const Real w_low = e_low / (Real(-2) * (Real(1) + z) * (Real(1) + z_f));
  Real result = w_low;
  if (z < z_f) {
    // E[(t² - 1)(t - z_f)] / ((z² - 1)(z - z_f))
    result += denominator / ((z * z - Real(1)) * (z - z_f));
  }
  return Saturate(result);
}

// ---- batched single precision (OcclusionFractions) ------------------------------------------

// Texels per block: transposed from PowerMomentsF to one array per moment on the stack (5 KiB).
constexpr int kBatchBlock = 256;

// Hamburger4Occlusion on `count` texels (a multiple of 8) given as planes m0..m4 and queries z,
// eight at a time with AVX2 + FMA: BiasedMoments, ClampQuery, FactorHankel, SolveAtQuery,
// RootOffsets and SupportWeight above with the same float operations in the same order (FMA
// exactly where they call std::fma), every branch of HamburgerBiased computed and selected
// (lanes whose branch is not taken may compute inf or NaN; the selects drop them). Hence the
// results equal the scalar function's. Written with intrinsics rather than `#pragma omp simd`:
// GCC keeps std::sqrt's errno path as a branch and then refuses to vectorize the loop unless the
// whole file is built with -fno-math-errno. fp-contract=off: GCC would otherwise fuse the
// separate multiplies and adds (b'_2 = keep b_2 + even, q_1 = s_1 - l_21 s_2) into FMAs, which
// the scalar functions, built for plain x86-64, round twice.
//
// std::max(x, k) = x < k ? k : x is _mm256_max_ps(k, x) (MAXPS returns its second operand when
// the first is not greater, NaN included), std::min(a, c) = c < a ? c : a is _mm256_min_ps(c, a);
// comparisons are ordered (false on NaN), like C++'s.
#if defined(__clang__)
// Clang contracts only within one source expression (-ffp-contract=on), and these kernels
// spell every multiply and add as its own intrinsic: nothing is fused that is not written so.
#define TRANSIENT_AVX2_FMA __attribute__((target("avx2,fma")))
#else
#define TRANSIENT_AVX2_FMA __attribute__((target("avx2,fma"), optimize("fp-contract=off")))
#endif

// All-ones exponent (NaN or infinity), as integer lanes of -1 / 0.
TRANSIENT_AVX2_FMA inline __m256i NonFinite8(__m256 v) {
  const __m256i exponent = _mm256_set1_epi32(0x7f800000);
  return _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_castps_si256(v), exponent), exponent);
}

// HamburgerBiased's Saturate: v >= 0 ? std::min(v, 1) : 0.
TRANSIENT_AVX2_FMA inline __m256 Saturate8(__m256 v) {
  const __m256 zero = _mm256_setzero_ps();
  return _mm256_blendv_ps(zero, _mm256_min_ps(_mm256_set1_ps(1.0f), v),
                          _mm256_cmp_ps(v, zero, _CMP_GE_OQ));
}

TRANSIENT_AVX2_FMA void HamburgerBlockAvx2(
    const float* m0, const float* m1, const float* m2, const float* m3, const float* m4,
    const float* z, int count, float alpha, float b_star_even, float* out) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 limit = _mm256_set1_ps(static_cast<float>(kMaxQueryDepth));
  const __m256 neg_limit = _mm256_set1_ps(-static_cast<float>(kMaxQueryDepth));
  const __m256 min_pivot = _mm256_set1_ps(1e-30f);   // FactorHankel's kMinPivot
  const __m256 far_away = _mm256_set1_ps(-1e4f);     // HamburgerBiased's -kFarAway
  const __m256 sign = _mm256_set1_ps(-0.0f);
  const __m256 one_minus_alpha = _mm256_set1_ps(1.0f - alpha);
  const __m256 even = _mm256_set1_ps(alpha * b_star_even);
  for (int i = 0; i < count; i += 8) {
    const __m256 b0 = _mm256_loadu_ps(m0 + i), raw1 = _mm256_loadu_ps(m1 + i),
                 raw2 = _mm256_loadu_ps(m2 + i), raw3 = _mm256_loadu_ps(m3 + i),
                 raw4 = _mm256_loadu_ps(m4 + i), query = _mm256_loadu_ps(z + i);
    // BiasedMoments and ClampQuery: degenerate input gives 0.
    const __m256i bad = _mm256_or_si256(
        _mm256_or_si256(_mm256_or_si256(NonFinite8(b0), NonFinite8(raw1)),
                        _mm256_or_si256(NonFinite8(raw2), NonFinite8(raw3))),
        NonFinite8(raw4));
    const __m256 usable = _mm256_andnot_ps(
        _mm256_castsi256_ps(bad), _mm256_and_ps(_mm256_cmp_ps(b0, zero, _CMP_GT_OQ),
                                                _mm256_cmp_ps(query, query, _CMP_ORD_Q)));
    const __m256 keep = _mm256_div_ps(one_minus_alpha, b0);
    const __m256 b1 = _mm256_mul_ps(keep, raw1);
    const __m256 b2 = _mm256_add_ps(_mm256_mul_ps(keep, raw2), even);
    const __m256 b3 = _mm256_mul_ps(keep, raw3);
    const __m256 b4 = _mm256_add_ps(_mm256_mul_ps(keep, raw4), even);
    const __m256 z_f = _mm256_min_ps(limit, _mm256_max_ps(neg_limit, query));
    // FactorHankel.
    const __m256 d1 = _mm256_max_ps(min_pivot, _mm256_fnmadd_ps(b1, b1, b2));
    const __m256 t = _mm256_fnmadd_ps(b1, b2, b3);
    const __m256 l21 = _mm256_div_ps(t, d1);
    const __m256 d2 =
        _mm256_max_ps(min_pivot, _mm256_fnmadd_ps(l21, t, _mm256_fnmadd_ps(b2, b2, b4)));
    // SolveAtQuery.
    const __m256 y1 = _mm256_sub_ps(z_f, b1);
    const __m256 y2 = _mm256_fnmadd_ps(l21, y1, _mm256_fmsub_ps(z_f, z_f, b2));
    const __m256 s1 = _mm256_div_ps(y1, d1);
    const __m256 s2 = _mm256_div_ps(y2, d2);
    const __m256 q2 = s2;
    const __m256 q1 = _mm256_sub_ps(s1, _mm256_mul_ps(l21, s2));
    const __m256 value = _mm256_fmadd_ps(y2, s2, _mm256_fmadd_ps(y1, s1, one));
    const __m256 slope = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_set1_ps(2.0f), q2), z_f, q1);
    // q2 > 0: z_f outside the roots: 0 left of both, 1 - w_0 right of both.
    const __m256 outside =
        _mm256_blendv_ps(Saturate8(_mm256_sub_ps(one, _mm256_div_ps(one, value))), zero,
                         _mm256_cmp_ps(slope, zero, _CMP_LE_OQ));
    // q2 < 0: RootOffsets and SupportWeight at the lower root.
    const __m256 minus_4ac = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(-4.0f), q2), value);
    const __m256 discriminant = _mm256_max_ps(zero, _mm256_fmadd_ps(slope, slope, minus_4ac));
    const __m256 root_term = _mm256_or_ps(_mm256_andnot_ps(sign, _mm256_sqrt_ps(discriminant)),
                                          _mm256_and_ps(sign, slope));  // copysign
    const __m256 half = _mm256_mul_ps(_mm256_set1_ps(-0.5f), _mm256_add_ps(slope, root_term));
    const __m256 a = _mm256_div_ps(half, q2);
    const __m256 c = _mm256_div_ps(value, half);
    const __m256 u_low = _mm256_min_ps(c, a);
    const __m256 root = _mm256_add_ps(z_f, u_low);
    const __m256 e1 = _mm256_sub_ps(root, b1);
    const __m256 e2 = _mm256_fnmadd_ps(l21, e1, _mm256_fmsub_ps(root, root, b2));
    const __m256 form = _mm256_fmadd_ps(e2, _mm256_div_ps(e2, d2),
                                        _mm256_fmadd_ps(e1, _mm256_div_ps(e1, d1), one));
    const __m256 between = _mm256_blendv_ps(zero, Saturate8(_mm256_div_ps(one, form)),
                                            _mm256_cmp_ps(u_low, far_away, _CMP_GT_OQ));
    // q2 == 0 (or NaN): thm. 4.1's failure point, 0.
    __m256 result = _mm256_blendv_ps(zero, between, _mm256_cmp_ps(q2, zero, _CMP_LT_OQ));
    result = _mm256_blendv_ps(result, outside, _mm256_cmp_ps(q2, zero, _CMP_GT_OQ));
    _mm256_storeu_ps(out + i, _mm256_and_ps(result, usable));
  }
}
#undef TRANSIENT_AVX2_FMA

}  // namespace

absl::Status DepthNormalisation::Validate() const {
  if (!std::isfinite(near_m) || !std::isfinite(far_m)) {
    return absl::InvalidArgumentError(absl::StrCat("depth normalisation near_m = ", near_m,
                                                   ", far_m = ", far_m,
                                                   ". Violated constraint: both finite"));
  }
  if (!(near_m < far_m)) {
    return absl::InvalidArgumentError(absl::StrCat("depth normalisation near_m = ", near_m,
                                                   ", far_m = ", far_m,
                                                   ". Violated constraint: near_m < far_m"));
  }
  return absl::OkStatus();
}

DepthSample DepthMoments(double depth_m, const DepthNormalisation& normalisation,
                         PowerMoments* moments) {
  assert(normalisation.Validate().ok());
  if (!std::isfinite(depth_m)) {
    moments->fill(0.0);
    return DepthSample::kInvalid;
  }
  const double unclamped = normalisation.Normalise(depth_m);
  const double z = std::clamp(unclamped, -1.0, 1.0);
  const double z2 = z * z;
  *moments = {1.0, z, z2, z2 * z, z2 * z2};
  return z == unclamped ? DepthSample::kValid : DepthSample::kClamped;
}

DepthSample WeightedDepthMoments(std::span<const double> depths_m,
                                 std::span<const double> weights,
                                 const DepthNormalisation& normalisation, PowerMoments* moments) {
  assert(depths_m.size() == weights.size());
  PowerMoments sum{};
  bool clamped = false, dropped = false;
  for (size_t l = 0; l < depths_m.size(); ++l) {
    const double w = weights[l];
    PowerMoments one;
    if (!(std::isfinite(w) && w > 0.0) ||
        DepthMoments(depths_m[l], normalisation, &one) == DepthSample::kInvalid) {
      dropped = true;
      continue;
    }
    clamped |= normalisation.Normalise(depths_m[l]) != one[1];
    for (int j = 0; j < kPowerMomentCount; ++j) sum[j] += w * one[j];
  }
  if (!(sum[0] > 0.0) || !std::isfinite(sum[0])) {
    moments->fill(0.0);
    return DepthSample::kInvalid;
  }
  const double scale = 1.0 / sum[0];
  for (int j = 0; j < kPowerMomentCount; ++j) (*moments)[j] = sum[j] * scale;
  (*moments)[0] = 1.0;
  if (dropped) return DepthSample::kDropped;
  return clamped ? DepthSample::kClamped : DepthSample::kValid;
}

double Hamburger4OcclusionReference(const PowerMoments& moments, double z_f,
                                    const MomentBias& bias) {
  PowerMoments b;
  if (!BiasedMoments(moments, bias, &b) || !ClampQuery(&z_f)) return 0.0;
  const ThreePointSolution solution = HamburgerThreePoint(b, z_f);
  return solution.ok ? Saturate(solution.occlusion) : 0.0;
}

float Hamburger4Occlusion(const PowerMomentsF& moments, float z_f, const MomentBias& bias) {
  PowerMomentsF b;
  if (!BiasedMoments(moments, bias, &b) || !ClampQuery(&z_f)) return 0.0f;
  return HamburgerBiased(b, z_f);
}

double Hausdorff4OcclusionReference(const PowerMoments& moments, double z_f,
                                    const MomentBias& bias) {
  PowerMoments b;
  if (!BiasedMoments(moments, bias, &b) || std::isnan(z_f)) return 0.0;
  if (z_f <= -1.0) return 0.0;
  if (z_f > 1.0) return 1.0;
  const ThreePointSolution solution = HamburgerThreePoint(b, z_f);
  if (solution.ok && solution.z1 >= -1.0 && solution.z2 <= 1.0) {
    return Saturate(solution.occlusion);
  }
  // Four-point branch by dense solve (supplement 000 alg. 4, step 6 on [-1, 1]).
  const double numerator = b[4] - b[2] + z_f * (b[1] - b[3]);
  const double denominator = b[3] - b[1] + z_f * (1.0 - b[2]);
  const double z = numerator / denominator;
  const double nodes[4] = {-1.0, z, z_f, 1.0};
  Eigen::Matrix4d vandermonde;
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 4; ++i) vandermonde(j, i) = std::pow(nodes[i], j);
  }
  const Eigen::Vector4d w =
      vandermonde.fullPivLu().solve(Eigen::Vector4d(b[0], b[1], b[2], b[3]));
  if (!w.allFinite()) return 0.0;
  double result = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (nodes[i] < z_f) result += w[i];
  }
  return Saturate(result);
}

float Hausdorff4Occlusion(const PowerMomentsF& moments, float z_f, const MomentBias& bias) {
  PowerMomentsF b;
  if (!BiasedMoments(moments, bias, &b) || std::isnan(z_f)) return 0.0f;
  if (z_f <= -1.0f) return 0.0f;
  if (z_f > 1.0f) return 1.0f;
  // The three-point (Hamburger) solution applies when its support lies inside [-1, 1].
  const HankelLdlt f = FactorHankel(b);
  const QuadraticAtQuery q = SolveAtQuery(f, z_f);
  float u_low, u_high;
  RootOffsets(q, &u_low, &u_high);
  const float z_low = z_f + u_low, z_high = z_f + u_high;  // +-inf or NaN: four-point branch
  if (z_low >= -1.0f && z_high <= 1.0f) return HamburgerBiased(b, z_f);
  return HausdorffFourPoint(b, z_f);
}

double VarianceOcclusionReference(const PowerMoments& moments, double z_f,
                                  const MomentBias& bias) {
  PowerMoments b;
  if (!BiasedMoments(moments, bias, &b) || !ClampQuery(&z_f)) return 0.0;
  const double mean = b[1];
  const double variance = std::max(b[2] - b[1] * b[1], 0.0);
  if (z_f <= mean) return 0.0;
  const double d2 = (z_f - mean) * (z_f - mean);
  return Saturate(d2 / (variance + d2));
}

float VarianceOcclusion(const PowerMomentsF& moments, float z_f, const MomentBias& bias) {
  PowerMomentsF b;
  if (!BiasedMoments(moments, bias, &b) || !ClampQuery(&z_f)) return 0.0f;
  const float variance = std::max(std::fma(-b[1], b[1], b[2]), 0.0f);
  const float d = z_f - b[1];
  if (d <= 0.0f) return 0.0f;
  return Saturate(d * d / std::fma(d, d, variance));
}

float OcclusionFraction(const PowerMomentsF& moments, float z_f) {
  return Hamburger4Occlusion(moments, z_f, kFloatMomentBias);
}

void OcclusionFractions(std::span<const PowerMomentsF> moments, std::span<const float> z_f,
                        std::span<float> out, const MomentBias& bias) {
  assert(moments.size() == z_f.size() && moments.size() == out.size());
  static const bool kAvx2Fma = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  size_t begin = 0;
  if (kAvx2Fma) {
    const float alpha = static_cast<float>(bias.alpha);
    const float b_star_even = static_cast<float>(bias.b_star_even);
    alignas(32) float planes[kPowerMomentCount][kBatchBlock];
    for (; begin + 8 <= moments.size(); begin += kBatchBlock) {
      // Whole groups of 8 only; the rest goes to the scalar loop below.
      const int count =
          static_cast<int>(std::min<size_t>(kBatchBlock, moments.size() - begin) / 8 * 8);
      for (int i = 0; i < count; ++i) {
        const PowerMomentsF& b = moments[begin + static_cast<size_t>(i)];
        for (int j = 0; j < kPowerMomentCount; ++j) planes[j][i] = b[static_cast<size_t>(j)];
      }
      HamburgerBlockAvx2(planes[0], planes[1], planes[2], planes[3], planes[4],
                         z_f.data() + begin, count, alpha, b_star_even, out.data() + begin);
      if (count < kBatchBlock) {
        begin += static_cast<size_t>(count);
        break;
      }
    }
  }
  for (; begin < moments.size(); ++begin) {
    out[begin] = Hamburger4Occlusion(moments[begin], z_f[begin], bias);
  }
}

}  // namespace transient

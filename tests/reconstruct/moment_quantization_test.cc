#include "transient/reconstruct/moment_quantization.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace transient {
namespace {

// One 16-bit step is 1/65535 of a channel's range; rounding errs by at most half a step.
constexpr double kHalfStep = 0.5 / 65535.0;

PowerMoments MomentsOf(const std::vector<double>& z, const std::vector<double>& w) {
  PowerMoments b{};
  for (size_t l = 0; l < z.size(); ++l) {
    double power = 1.0;
    for (int j = 0; j < kPowerMomentCount; ++j, power *= z[l]) b[j] += w[l] * power;
  }
  return b;
}

PowerMomentsF ToFloatForTest(const PowerMoments& b) {
  PowerMomentsF f;
  for (int j = 0; j < kPowerMomentCount; ++j) f[j] = static_cast<float>(b[j]);
  return f;
}

// 1..6 random depths in [-1, 1] (some clustered, some at the ends) with weights summing to 1.
PowerMoments RandomMoments(int trial, std::mt19937_64& rng, std::vector<double>* depths = nullptr,
                           std::vector<double>* weights = nullptr) {
  std::uniform_real_distribution<double> depth(-1.0, 1.0), weight(0.01, 1.0);
  std::vector<double> z, w;
  const int count = 1 + trial % 6;
  double total = 0.0;
  for (int l = 0; l < count; ++l) {
    double zl = depth(rng);
    if (trial % 5 == 0) zl = (rng() % 2) ? 1.0 : -1.0;
    if (trial % 7 == 0 && l > 0) zl = std::clamp(z[0] + 1e-3 * depth(rng), -1.0, 1.0);
    z.push_back(zl);
    w.push_back(weight(rng));
    total += w.back();
  }
  for (double& wl : w) wl /= total;
  if (depths) *depths = z;
  if (weights) *weights = w;
  return MomentsOf(z, w);
}

// ---- optimized affine quantization -----------------------------------------------------------

TEST(OptimizedQuantization, MapsEveryDepthIntoTheUnitCube) {
  // Θ maps conv b([-1, 1]) into [0, 1]^4 (thesis §4.1.4); its corners are attained.
  for (double z = -1.0; z <= 1.0; z += 1.0 / 512.0) {
    const std::array<double, 4> theta = OptimizedTransform(MomentsOf({z}, {1.0}));
    for (const double t : theta) {
      EXPECT_GE(t, -1e-15) << z;
      EXPECT_LE(t, 1.0 + 1e-15) << z;
    }
  }
  EXPECT_NEAR(OptimizedTransform(MomentsOf({0.5}, {1.0}))[0], 1.0, 1e-15);
  EXPECT_NEAR(OptimizedTransform(MomentsOf({-0.5}, {1.0}))[0], 0.0, 1e-15);
  EXPECT_NEAR(OptimizedTransform(MomentsOf({std::sqrt(0.75)}, {1.0}))[2], 1.0, 1e-15);
  EXPECT_NEAR(OptimizedTransform(MomentsOf({std::sqrt(0.5)}, {1.0}))[1], 1.0, 1e-15);
}

TEST(OptimizedQuantization, InverseUndoesTheTransform) {
  std::mt19937_64 rng(51);
  for (int trial = 0; trial < 200; ++trial) {
    const PowerMoments b = RandomMoments(trial, rng);
    const PowerMoments back = InverseOptimizedTransform(OptimizedTransform(b));
    for (int j = 0; j < kPowerMomentCount; ++j) EXPECT_NEAR(back[j], b[j], 1e-14) << j;
  }
}

TEST(OptimizedQuantization, RoundTripIsWithinSixteenBitPrecision) {
  // Half a step per channel, carried through the inverse: the absolute row sums of Θ⁻¹ are
  // 1/3 + √3 (b1), 1/8 + 1 (b2, b4) and 3/4 + 3√3/4 (b3). kFloatDecode adds float rounding.
  const double row_sum[kPowerMomentCount] = {0.0, 1.0 / 3.0 + std::sqrt(3.0), 1.125,
                                             0.75 + 0.75 * std::sqrt(3.0), 1.125};
  constexpr double kFloatDecode = 4e-7;
  std::mt19937_64 rng(52);
  for (int trial = 0; trial < 500; ++trial) {
    PowerMoments b = RandomMoments(trial, rng);
    QuantizedMoments64 q;
    ASSERT_TRUE(EncodeOptimized64(b, &q));
    const PowerMoments back = DecodeOptimized64(q);
    const PowerMomentsF back_f = DecodeOptimized64F(q);
    EXPECT_EQ(back[0], 1.0);
    for (int j = 1; j < kPowerMomentCount; ++j) {
      EXPECT_LE(std::abs(back[j] - b[j]), row_sum[j] * kHalfStep * (1 + 1e-9)) << j;
      EXPECT_NEAR(back_f[j], back[j], kFloatDecode) << j;
    }
  }
}

TEST(OptimizedQuantization, CoverageIsDividedOutBeforeEncoding) {
  PowerMoments b = MomentsOf({-0.2, 0.7}, {0.4, 0.6});
  QuantizedMoments64 full, quarter;
  ASSERT_TRUE(EncodeOptimized64(b, &full));
  for (double& v : b) v *= 0.25;
  ASSERT_TRUE(EncodeOptimized64(b, &quarter));
  EXPECT_EQ(full.channel, quarter.channel);
}

TEST(OptimizedQuantization, InvalidPixelEncodesAFarSurfaceAndIsReported) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  QuantizedMoments64 far, q;
  ASSERT_TRUE(EncodeOptimized64(MomentsOf({1.0}, {1.0}), &far));
  for (const PowerMoments& bad : {PowerMoments{0, 0, 0, 0, 0}, PowerMoments{1, nan, 0, 0, 0},
                                  PowerMoments{-2, 0.1, 0.2, 0.0, 0.1}}) {
    EXPECT_FALSE(EncodeOptimized64(bad, &q));
    EXPECT_EQ(q.channel, far.channel);
    EXPECT_LT(OcclusionFractionOptimized64(q, 0.9f), 0.01f);  // nothing in front of the far plane
  }
}

TEST(OptimizedQuantization, OcclusionFromSixtyFourBitsMatchesTheTruth) {
  // One surface at 0.2 and two at (-0.4, 0.5) with weights (0.3, 0.7); 16-bit codes decoded
  // with the adapted bias. Leak tolerance as for the float map, scaled by the larger α = 6e-5:
  // 1.375 α / m² = 0.033 at m = 0.05 (measured: 0.012 behind one surface, 3.4e-4 between two).
  constexpr double kLeak = 0.04;
  QuantizedMoments64 one, two;
  ASSERT_TRUE(EncodeOptimized64(MomentsOf({0.2}, {1.0}), &one));
  ASSERT_TRUE(EncodeOptimized64(MomentsOf({-0.4, 0.5}, {0.3, 0.7}), &two));
  EXPECT_LE(OcclusionFractionOptimized64(one, 0.15f), kQuantized16MomentBias.alpha + kLeak);
  EXPECT_GE(OcclusionFractionOptimized64(one, 0.25f), 1.0 - kLeak);
  EXPECT_NEAR(OcclusionFractionOptimized64(two, 0.0f), 0.3, kLeak);
  EXPECT_GE(OcclusionFractionOptimized64(two, 0.6f), 1.0 - kLeak);
  EXPECT_LE(OcclusionFractionOptimized64(two, -0.5f), kLeak);
}

TEST(OptimizedQuantization, QuantizedOcclusionStaysBelowTheTruthPlusBias) {
  // The adapted bias (thesis §4.1.4) keeps 16-bit rounding from raising the bound: never more
  // than α + kSlack above the true fraction (kSlack: the float evaluation, as for 128 bits).
  constexpr double kSlack = 5e-3;
  std::mt19937_64 rng(53);
  for (int trial = 0; trial < 500; ++trial) {
    std::vector<double> z, w;
    const PowerMoments b = RandomMoments(trial, rng, &z, &w);
    QuantizedMoments64 q;
    ASSERT_TRUE(EncodeOptimized64(b, &q));
    for (int s = 0; s < 6; ++s) {
      const float z_f = static_cast<float>(std::uniform_real_distribution<double>(-1, 1)(rng));
      double truth = 0.0;
      for (size_t l = 0; l < z.size(); ++l) truth += z[l] < z_f ? w[l] : 0.0;
      EXPECT_LE(OcclusionFractionOptimized64(q, z_f),
                truth + kQuantized16MomentBias.alpha + kSlack)
          << trial << " " << z_f;
    }
  }
}

// ---- non-linear representation ---------------------------------------------------------------

TEST(NonLinearMoments, TwoSurfacesAreRepresentedExactly) {
  // Two surfaces: S is the distribution itself, ξ4 = 0 (prop. 2.12, boundary case).
  NonLinearMoments n;
  ASSERT_TRUE(ToNonLinear(MomentsOf({-0.3, 0.6}, {0.25, 0.75}), &n));
  EXPECT_NEAR(n.y1, -0.3, 1e-12);
  EXPECT_NEAR(n.y2, 0.6, 1e-12);
  EXPECT_NEAR(n.v2, 0.75, 1e-12);
  EXPECT_NEAR(n.xi4, 0.0, 1e-12);
}

TEST(NonLinearMoments, SingleSurfaceCollapsesToOnePoint) {
  NonLinearMoments n;
  ASSERT_TRUE(ToNonLinear(MomentsOf({0.4}, {1.0}), &n));
  EXPECT_DOUBLE_EQ(n.y1, 0.4);
  EXPECT_DOUBLE_EQ(n.y2, 0.4);
  EXPECT_EQ(n.v2, 0.0);
  EXPECT_NEAR(n.xi4, 0.0, 1e-15);
}

TEST(NonLinearMoments, SatisfyTheSupplementBoundsAndReproduceTheMoments) {
  // Props. 2 and 3 of supplement 003 for distributions on [-1, 1]; FromNonLinear inverts.
  std::mt19937_64 rng(54);
  for (int trial = 0; trial < 500; ++trial) {
    const PowerMoments b = RandomMoments(trial, rng);
    NonLinearMoments n;
    ASSERT_TRUE(ToNonLinear(b, &n));
    // The roots are conditioned like eps / variance (b2 - b1² loses the leading digits of b2):
    // ~4 eps / variance covers it (clusters 1e-3 wide reach variances of ~1e-9).
    const double kRounding =
        1e-15 / std::max(b[2] - b[1] * b[1], kMinNonLinearVariance) + 1e-12;
    EXPECT_GE(n.y1, -1.0 - kRounding);
    EXPECT_LE(n.y2, 1.0 + kRounding);
    EXPECT_LE(n.y1, n.y2);
    EXPECT_GE(n.v2, 0.0);
    EXPECT_LE(n.v2, 1.0);
    EXPECT_GE(n.xi4, 0.0);
    EXPECT_LE(n.xi4, 0.25 + kRounding);
    const PowerMoments back = FromNonLinear(n);
    // Clustered depths (1e-3 apart) condition the roots like 1/variance: 1e-8 covers them.
    for (int j = 0; j < kPowerMomentCount; ++j) EXPECT_NEAR(back[j], b[j], 1e-8) << j;
  }
}

TEST(NonLinearMoments, XiFourBoundIsSharp) {
  // 0.25 δ_{-1} + 0.5 δ_0 + 0.25 δ_1 has b = (1, 0, 0.5, 0, 0.5) and ξ4 = 0.25 (prop. 3).
  NonLinearMoments n;
  ASSERT_TRUE(ToNonLinear(MomentsOf({-1.0, 0.0, 1.0}, {0.25, 0.5, 0.25}), &n));
  EXPECT_NEAR(n.xi4, 0.25, 1e-15);
}

TEST(NonLinearMoments, XiFourScalesWithTheFourthPowerOfDepthScale) {
  // Prop. 4: with c = 1/(y2 - y1), d = -c y1, the depths c z + d have y1' = 0, y2' = 1,
  // v2' = v2 and ξ4' = c⁴ ξ4.
  std::mt19937_64 rng(55);
  int checked = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<double> z, w;
    const PowerMoments b = RandomMoments(trial, rng, &z, &w);
    NonLinearMoments n;
    ASSERT_TRUE(ToNonLinear(b, &n));
    if (n.y2 - n.y1 < 0.05) continue;  // c would amplify rounding beyond the tolerance below
    const double c = 1.0 / (n.y2 - n.y1), d = -c * n.y1;
    std::vector<double> scaled;
    for (const double zl : z) scaled.push_back(c * zl + d);
    NonLinearMoments s;
    ASSERT_TRUE(ToNonLinear(MomentsOf(scaled, w), &s));
    EXPECT_NEAR(s.y1, 0.0, 1e-9);
    EXPECT_NEAR(s.y2, 1.0, 1e-9);
    EXPECT_NEAR(s.v2, n.v2, 1e-9);
    EXPECT_NEAR(s.xi4, std::pow(c, 4) * n.xi4, 1e-9 * std::max(1.0, std::pow(c, 4)));
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(NonLinearMoments, SupportPointsSplitTheQueriesIntoTheThreeCases) {
  // Supplement 003 prop. 1: unbiased, the bound is 0 up to y1 and positive beyond it.
  const PowerMoments b = MomentsOf({-0.6, 0.1, 0.7}, {0.3, 0.3, 0.4});
  NonLinearMoments n;
  ASSERT_TRUE(ToNonLinear(b, &n));
  const MomentBias no_bias{0.0, 0.375};
  EXPECT_EQ(Hamburger4OcclusionReference(b, n.y1 - 1e-3, no_bias), 0.0);
  EXPECT_GT(Hamburger4OcclusionReference(b, n.y1 + 1e-3, no_bias), 0.0);
  EXPECT_EQ(Hamburger4Occlusion(ToFloatForTest(b), static_cast<float>(n.y1 - 1e-3), no_bias),
            0.0f);
}

TEST(NonLinearMoments, SixteenBitRoundTripIsWithinPrecision) {
  // y steps are 2/65535 (error <= 2 kHalfStep), v2 and sqrt(4 ξ4) err by <= kHalfStep, hence
  // ξ4 by <= kHalfStep/2 + tiny. b_j = (1 - v2) y1^j + v2 y2^j moves by <= j·2 kHalfStep (from
  // y) + 2 kHalfStep (from v2, |y2^j - y1^j| <= 2), plus the ξ4 error for b4.
  std::mt19937_64 rng(56);
  for (int trial = 0; trial < 500; ++trial) {
    const PowerMoments b = RandomMoments(trial, rng);
    QuantizedMoments64 q;
    ASSERT_TRUE(EncodeNonLinear64(b, &q));
    NonLinearMoments exact;
    ASSERT_TRUE(ToNonLinear(b, &exact));
    const NonLinearMoments decoded = DecodeNonLinear64(q);
    EXPECT_NEAR(decoded.y1, std::clamp(exact.y1, -1.0, 1.0), 2 * kHalfStep * (1 + 1e-9));
    EXPECT_NEAR(decoded.y2, std::clamp(exact.y2, -1.0, 1.0), 2 * kHalfStep * (1 + 1e-9));
    EXPECT_NEAR(decoded.v2, exact.v2, kHalfStep * (1 + 1e-9));
    EXPECT_LE(decoded.xi4, 0.25);
    const PowerMoments back = FromNonLinear(decoded);
    for (int j = 1; j < kPowerMomentCount; ++j) {
      const double bound = j * 2 * kHalfStep + 2 * kHalfStep + (j == 4 ? kHalfStep : 0.0);
      EXPECT_LE(std::abs(back[j] - b[j]), bound * 1.001 + 1e-8) << trial << " " << j;
    }
  }
}

TEST(NonLinearMoments, InvalidPixelIsReportedAndNeverNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  NonLinearMoments n;
  EXPECT_FALSE(ToNonLinear(PowerMoments{0, 0, 0, 0, 0}, &n));
  EXPECT_FALSE(ToNonLinear(PowerMoments{1, 0.2, nan, 0, 0}, &n));
  QuantizedMoments64 q;
  EXPECT_FALSE(EncodeNonLinear64(PowerMoments{1, 0.2, nan, 0, 0}, &q));
  const NonLinearMoments decoded = DecodeNonLinear64(q);
  EXPECT_EQ(decoded.y1, 1.0);  // a surface at the far plane
  EXPECT_EQ(decoded.y2, 1.0);
}

}  // namespace
}  // namespace transient

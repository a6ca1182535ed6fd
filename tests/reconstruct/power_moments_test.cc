#include "transient/reconstruct/power_moments.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "tests/reconstruct/depth_mixture.h"
#include "tests/support/status_matchers.h"
#include "transient/reconstruct/image.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr double kInf = std::numeric_limits<double>::infinity();

using Mixture = testing::DepthMixture;  // tests/reconstruct/depth_mixture.h

PowerMomentsF ToFloat(const PowerMoments& b) {
  PowerMomentsF f;
  for (int j = 0; j < kPowerMomentCount; ++j) f[j] = static_cast<float>(b[j]);
  return f;
}

// 1..8 surfaces; a fifth of them at the ends of the range and a seventh as clusters 1e-4 wide,
// which puts the Hankel matrix next to singular (prop. 2.12: a single depth is singular).
Mixture RandomMixture(int trial, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> depth(-1.0, 1.0), weight(0.01, 1.0);
  Mixture m;
  const int count = 1 + trial % 8;
  double total = 0.0;
  for (int l = 0; l < count; ++l) {
    double z = depth(rng);
    if (trial % 5 == 0) z = (rng() % 2) ? 1.0 : -1.0;
    if (trial % 7 == 0 && l > 0) z = std::clamp(m.z[0] + 1e-4 * depth(rng), -1.0, 1.0);
    m.z.push_back(z);
    m.w.push_back(weight(rng));
    total += m.w.back();
  }
  for (double& w : m.w) w /= total;
  return m;
}

// ---- normalisation and moments -----------------------------------------------------------------

TEST(DepthNormalisation, ValidRangeIsAccepted) {
  EXPECT_THAT((DepthNormalisation{0.5, 4.0}.Validate()), IsOk());
}

TEST(DepthNormalisation, EmptyOrReversedRangeIsRejected) {
  EXPECT_THAT((DepthNormalisation{2.0, 2.0}.Validate()),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("near_m < far_m")));
  EXPECT_THAT((DepthNormalisation{3.0, 1.0}.Validate()),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("near_m = 3")));
}

TEST(DepthNormalisation, NonFiniteRangeIsRejected) {
  EXPECT_THAT((DepthNormalisation{kNaN, 1.0}.Validate()),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("finite")));
  EXPECT_THAT((DepthNormalisation{0.0, kInf}.Validate()),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("finite")));
}

TEST(DepthNormalisation, MapsNearToMinusOneAndFarToOne) {
  const DepthNormalisation n{0.5, 4.5};
  EXPECT_DOUBLE_EQ(n.Normalise(0.5), -1.0);
  EXPECT_DOUBLE_EQ(n.Normalise(4.5), 1.0);
  EXPECT_DOUBLE_EQ(n.Normalise(2.5), 0.0);
  EXPECT_DOUBLE_EQ(n.Denormalise(n.Normalise(3.7)), 3.7);
}

TEST(DepthMoments, OneDepthGivesItsPowers) {
  const DepthNormalisation n{1.0, 3.0};
  PowerMoments b;
  EXPECT_EQ(DepthMoments(2.5, n, &b), DepthSample::kValid);
  EXPECT_THAT(b, ::testing::ElementsAre(1.0, 0.5, 0.25, 0.125, 0.0625));
}

TEST(DepthMoments, OutOfRangeDepthIsClampedAndFlagged) {
  const DepthNormalisation n{1.0, 3.0};
  PowerMoments b;
  EXPECT_EQ(DepthMoments(7.0, n, &b), DepthSample::kClamped);
  EXPECT_THAT(b, ::testing::ElementsAre(1.0, 1.0, 1.0, 1.0, 1.0));
  EXPECT_EQ(DepthMoments(0.2, n, &b), DepthSample::kClamped);
  EXPECT_THAT(b, ::testing::ElementsAre(1.0, -1.0, 1.0, -1.0, 1.0));
}

TEST(DepthMoments, NonFiniteDepthHasZeroWeight) {
  const DepthNormalisation n{1.0, 3.0};
  for (const double bad : {kNaN, kInf, -kInf}) {
    PowerMoments b;
    b.fill(7.0);
    EXPECT_EQ(DepthMoments(bad, n, &b), DepthSample::kInvalid);
    EXPECT_THAT(b, ::testing::Each(0.0));
  }
}

TEST(WeightedDepthMoments, ReproducesTheNormalisedMixture) {
  const DepthNormalisation n{0.0, 2.0};  // z̄ = depth - 1
  const std::vector<double> depths = {0.5, 1.0, 1.75};
  const std::vector<double> weights = {2.0, 1.0, 1.0};  // sum 4: normalised to 0.5, 0.25, 0.25
  PowerMoments b;
  EXPECT_EQ(WeightedDepthMoments(depths, weights, n, &b), DepthSample::kValid);
  const Mixture expected{{-0.5, 0.0, 0.75}, {0.5, 0.25, 0.25}};
  const PowerMoments want = expected.Powers();
  for (int j = 0; j < kPowerMomentCount; ++j) EXPECT_NEAR(b[j], want[j], 1e-15) << j;
}

TEST(WeightedDepthMoments, DropsUnusableEntriesAndSaysSo) {
  const DepthNormalisation n{0.0, 2.0};
  const std::vector<double> depths = {1.5, kNaN, 0.5, 1.0};
  const std::vector<double> weights = {1.0, 1.0, -1.0, kNaN};
  PowerMoments b;
  EXPECT_EQ(WeightedDepthMoments(depths, weights, n, &b), DepthSample::kDropped);
  EXPECT_THAT(b, ::testing::ElementsAre(1.0, 0.5, 0.25, 0.125, 0.0625));  // only 1.5 m is left
}

TEST(WeightedDepthMoments, NothingUsableGivesZeroCoverage) {
  const DepthNormalisation n{0.0, 2.0};
  const std::vector<double> depths = {kNaN, 1.0};
  const std::vector<double> weights = {1.0, 0.0};
  PowerMoments b;
  EXPECT_EQ(WeightedDepthMoments(depths, weights, n, &b), DepthSample::kInvalid);
  EXPECT_THAT(b, ::testing::Each(0.0));
  EXPECT_EQ(WeightedDepthMoments({}, {}, n, &b), DepthSample::kInvalid);
}

TEST(WeightedDepthMoments, ClampedDepthIsReported) {
  const DepthNormalisation n{0.0, 2.0};
  const std::vector<double> depths = {1.0, 9.0};
  const std::vector<double> weights = {1.0, 1.0};
  PowerMoments b;
  EXPECT_EQ(WeightedDepthMoments(depths, weights, n, &b), DepthSample::kClamped);
  EXPECT_DOUBLE_EQ(b[1], 0.5);  // surfaces at z̄ = 0 and (clamped) 1
}

// ---- known answers ---------------------------------------------------------------------------

// Bounds of the bias's effect for a single surface at d with b' = (1 - α) b + α b*: the biased
// variance is α(1 - α) d² + 0.375 α <= 1.375 α and the mean moves by at most α. Hamburger is at
// least the VSM (Cantelli) bound, so at a distance m behind the surface the result is at least
// 1 - 1.375 α / (m - α)²; in front of it the result is at most α (thesis §4.1.3).
// kFloatSlack: the float path's departure from exact arithmetic away from surfaces, measured
// <= 2e-3 on 4e5 random queries (float rounding of moments near the singular boundary).
constexpr double kFloatSlack = 5e-3;
constexpr double kDoubleSlack = 1e-9;  // dense 3x3 solves at condition ~ 1/α

double SingleSurfaceLeak(double alpha, double margin) {
  return 1.375 * alpha / ((margin - alpha) * (margin - alpha));
}

TEST(Hamburger4, OneSurfaceOccludesBehindItAndNothingInFront) {
  const double alpha = kFloatMomentBias.alpha;
  constexpr double kMargin = 0.05;
  for (const double d : {-1.0, -0.6, 0.0, 0.3, 0.95, 1.0}) {
    const Mixture surface{{d}, {1.0}};
    const PowerMoments b = surface.Powers();
    for (const double offset : {kMargin, 0.2, 0.5}) {
      if (d + offset <= 1.0) {
        EXPECT_GE(Hamburger4OcclusionReference(b, d + offset, kFloatMomentBias),
                  1.0 - SingleSurfaceLeak(alpha, offset) - kDoubleSlack)
            << d << " " << offset;
        EXPECT_GE(OcclusionFraction(ToFloat(b), static_cast<float>(d + offset)),
                  1.0 - SingleSurfaceLeak(alpha, offset) - kFloatSlack)
            << d << " " << offset;
      }
      if (d - offset >= -1.0) {
        EXPECT_LE(Hamburger4OcclusionReference(b, d - offset, kFloatMomentBias),
                  alpha + kDoubleSlack);
        EXPECT_LE(OcclusionFraction(ToFloat(b), static_cast<float>(d - offset)),
                  alpha + kFloatSlack);
      }
    }
  }
}

// Two surfaces (weights w, 1 - w) have a singular Hankel matrix (prop. 2.12): the moments
// determine the distribution, so between the surfaces the sharp bound is exactly w. The bias
// can raise it by at most α. It lowers it by moving weight onto the query's own support point:
// w_0 = 1/Q(z_f) <= ξ4' / P(z_f)², where P(z) = (z - d1)(z - d2) is (to first order in α) the
// monic orthogonal polynomial of b' and ξ4' ≈ α E_{b*}[P²] its Schur complement. The test allows
// twice that, for the O(α²) terms and for w_0 being drawn from both neighbours.
double TwoSurfaceLeak(double d1, double d2, double z_f, double alpha) {
  auto p2 = [&](double z) { return (z - d1) * (z - d2) * (z - d1) * (z - d2); };
  // b* = (1, 0, 0.375, 0, 0.375) is the moment vector of 0.625 δ_0 + 0.1875 (δ_-1 + δ_1).
  const double expected = 0.625 * p2(0.0) + 0.1875 * (p2(-1.0) + p2(1.0));
  return 2.0 * alpha * expected / p2(z_f);
}

TEST(Hamburger4, TwoSurfacesGiveTheExactFractionBetweenThem) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> depth(-1.0, 1.0), weight(0.05, 0.95);
  constexpr double kMargin = 0.05;
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    double d1 = depth(rng), d2 = depth(rng);
    if (d2 - d1 < 0.0) std::swap(d1, d2);
    if (d2 - d1 < 3.0 * kMargin) continue;
    const double w = weight(rng);
    const Mixture two{{d1, d2}, {w, 1.0 - w}};
    const PowerMoments b = two.Powers();
    const double z_f = std::uniform_real_distribution<double>(d1 + kMargin, d2 - kMargin)(rng);
    const double leak = TwoSurfaceLeak(d1, d2, z_f, kFloatMomentBias.alpha);
    const double reference = Hamburger4OcclusionReference(b, z_f, kFloatMomentBias);
    EXPECT_LE(reference, w + kFloatMomentBias.alpha + kDoubleSlack);
    EXPECT_GE(reference, w - leak) << d1 << " " << d2 << " " << z_f;
    const float single = OcclusionFraction(ToFloat(b), static_cast<float>(z_f));
    EXPECT_NEAR(single, w, leak + kFloatSlack) << d1 << " " << d2 << " " << z_f;
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(Hamburger4, TwoDistantSurfacesLeakLittle) {
  // Surfaces at -0.5 and 0.5, queried midway: the leak bound above is 2.2e-4.
  const Mixture two{{-0.5, 0.5}, {0.3, 0.7}};
  EXPECT_LE(TwoSurfaceLeak(-0.5, 0.5, 0.0, kFloatMomentBias.alpha), 3e-4);
  EXPECT_NEAR(OcclusionFraction(ToFloat(two.Powers()), 0.0f), 0.3, 3e-4 + kFloatSlack);
  EXPECT_NEAR(Hamburger4OcclusionReference(two.Powers(), 0.0, kFloatMomentBias), 0.3, 3e-4);
}

TEST(Hamburger4, ThreePointSolutionThroughTheQueryIsExact) {
  // Theorem 4.1: with z_f one of three surfaces, the other two are recovered and the bound is
  // the exact mass in front. Without bias (α = 0) in double precision.
  const Mixture three{{-0.7, 0.1, 0.6}, {0.2, 0.5, 0.3}};
  const PowerMoments b = three.Powers();
  const MomentBias no_bias{0.0, 0.375};
  EXPECT_NEAR(Hamburger4OcclusionReference(b, 0.1, no_bias), 0.2, 1e-12);
  EXPECT_NEAR(Hamburger4OcclusionReference(b, 0.6, no_bias), 0.7, 1e-12);
  EXPECT_NEAR(Hamburger4Occlusion(ToFloat(b), 0.1f, no_bias), 0.2, 1e-4);
  EXPECT_NEAR(Hamburger4Occlusion(ToFloat(b), 0.6f, no_bias), 0.7, 1e-4);
}

// ---- bounds on random mixtures ----------------------------------------------------------------

// On every valid input and query, each bound stays below the true fraction plus α (thesis
// §4.1.3: the bias raises the sharp lower bound by at most α) up to rounding. The Hausdorff
// float path gets kHausdorffFloatSlack: its four-point weights divide by (1 + z̄_f)(1 + z) and
// amplify float rounding of the moments ~1e4-fold when z̄_f is within 1e-4 of -1 (measured
// overshoot 1.3e-4).
constexpr double kHausdorffFloatSlack = 5e-4;

TEST(PowerMomentBounds, NeverExceedTheTrueFractionByMoreThanTheBias) {
  std::mt19937_64 rng(42);
  const double alpha = kFloatMomentBias.alpha;
  for (int trial = 0; trial < 1000; ++trial) {
    const Mixture m = RandomMixture(trial, rng);
    const PowerMoments b = m.Powers();
    const PowerMomentsF bf = ToFloat(b);
    for (int s = 0; s < 8; ++s) {
      // Half the queries anywhere, half right next to a surface (the steepest places).
      double z_f = std::uniform_real_distribution<double>(-1.0, 1.0)(rng);
      if (s % 2) z_f = m.z[rng() % m.z.size()] + ((rng() % 2) ? 1e-3 : -1e-3);
      const float z_ff = static_cast<float>(z_f);
      const double truth = m.FractionInFront(z_ff);
      const double limit = truth + alpha;
      EXPECT_LE(Hamburger4OcclusionReference(b, z_ff, kFloatMomentBias), limit + kDoubleSlack);
      EXPECT_LE(Hausdorff4OcclusionReference(b, z_ff, kFloatMomentBias), limit + kDoubleSlack);
      EXPECT_LE(VarianceOcclusionReference(b, z_ff, kFloatMomentBias), limit + kDoubleSlack);
      EXPECT_LE(Hamburger4Occlusion(bf, z_ff, kFloatMomentBias), limit + 1e-6);
      EXPECT_LE(Hausdorff4Occlusion(bf, z_ff, kFloatMomentBias), limit + kHausdorffFloatSlack);
      EXPECT_LE(VarianceOcclusion(bf, z_ff, kFloatMomentBias), limit + 1e-6);
    }
  }
}

TEST(PowerMomentBounds, MoreKnowledgeNeverLoosensTheBound) {
  // Same biased moments: VSM uses two moments, Hamburger four, Hausdorff four plus the support
  // [-1, 1]; each feasible set contains the next, so the sharp lower bounds are ordered.
  std::mt19937_64 rng(43);
  for (int trial = 0; trial < 500; ++trial) {
    const Mixture m = RandomMixture(trial, rng);
    const PowerMoments b = m.Powers();
    for (int s = 0; s < 6; ++s) {
      const double z_f = std::uniform_real_distribution<double>(-1.0, 1.0)(rng);
      const double vsm = VarianceOcclusionReference(b, z_f, kFloatMomentBias);
      const double hamburger = Hamburger4OcclusionReference(b, z_f, kFloatMomentBias);
      const double hausdorff = Hausdorff4OcclusionReference(b, z_f, kFloatMomentBias);
      EXPECT_GE(hamburger, vsm - 1e-7) << trial << " " << z_f;
      EXPECT_GE(hausdorff, hamburger - 1e-7) << trial << " " << z_f;
    }
  }
}

TEST(VarianceShadowMap, IsTheChebyshevBoundOfTheLitFraction) {
  // Lit fraction Z(z̄ >= z̄_f) <= σ² / (σ² + (z̄_f - μ)²) (Cantelli) for z̄_f > μ: our VSM value
  // 1 - that is below the occluded fraction; unbiased, it is attained by a two-point mixture.
  const Mixture m{{-0.5, 0.5}, {0.5, 0.5}};  // μ = 0, σ² = 0.25
  const MomentBias no_bias{0.0, 0.375};
  EXPECT_NEAR(VarianceOcclusionReference(m.Powers(), 0.5, no_bias), 0.25 / 0.5, 1e-15);
  EXPECT_NEAR(VarianceOcclusion(ToFloat(m.Powers()), 0.5f, no_bias), 0.5, 1e-6);
  EXPECT_EQ(VarianceOcclusionReference(m.Powers(), -0.1, no_bias), 0.0);  // z̄_f <= μ
  std::mt19937_64 rng(44);
  for (int trial = 0; trial < 300; ++trial) {
    const Mixture r = RandomMixture(trial, rng);
    const double z_f = std::uniform_real_distribution<double>(-1.0, 1.0)(rng);
    const double lit_upper = 1.0 - VarianceOcclusionReference(r.Powers(), z_f, no_bias);
    EXPECT_GE(lit_upper, 1.0 - r.FractionInFront(z_f) - 1e-9);
  }
}

// ---- Hausdorff specifics ---------------------------------------------------------------------

TEST(Hausdorff4, KnowsThatDepthLiesInTheRange) {
  const Mixture m{{-0.2, 0.4}, {0.6, 0.4}};
  const PowerMoments b = m.Powers();
  EXPECT_EQ(Hausdorff4OcclusionReference(b, -1.0, kFloatMomentBias), 0.0);
  EXPECT_EQ(Hausdorff4OcclusionReference(b, 1.5, kFloatMomentBias), 1.0);
  EXPECT_EQ(Hausdorff4Occlusion(ToFloat(b), -3.0f, kFloatMomentBias), 0.0f);
  EXPECT_EQ(Hausdorff4Occlusion(ToFloat(b), 1.01f, kFloatMomentBias), 1.0f);
}

TEST(Hausdorff4, FourPointBranchIsSharperNearTheEndOfTheRange) {
  // Three surfaces with one at the near end: Hamburger may place mass below -1, Hausdorff not.
  // Unbiased, with z_f just behind the middle surface, the four-point solution is exact.
  const Mixture m{{-1.0, 0.2, 1.0}, {0.3, 0.4, 0.3}};
  const PowerMoments b = m.Powers();
  const MomentBias tiny{1e-9, 0.375};
  int sharper = 0;
  for (double z_f = -0.95; z_f < 0.95; z_f += 0.05) {
    const double hausdorff = Hausdorff4OcclusionReference(b, z_f, tiny);
    const double hamburger = Hamburger4OcclusionReference(b, z_f, tiny);
    EXPECT_LE(hausdorff, m.FractionInFront(z_f) + 1e-6) << z_f;
    EXPECT_GE(hausdorff, hamburger - 1e-9) << z_f;
    sharper += hausdorff > hamburger + 1e-3;
    const float single = Hausdorff4Occlusion(ToFloat(b), static_cast<float>(z_f), tiny);
    EXPECT_NEAR(single, hausdorff, 1e-3) << z_f;
  }
  EXPECT_GT(sharper, 0);
}

// ---- float against double ----------------------------------------------------------------------

TEST(PowerMomentBounds, FloatPathStaysWithinTheBias) {
  // Float on float-rounded moments against the double reference on the exact ones, queries at
  // least 0.01 from every surface (nearer, the bound is steep and any rounding moves it).
  // Measured max difference at α = 1e-5 on 4e5 queries: 2.0e-3 (kFloatSlack = 5e-3).
  std::mt19937_64 rng(45);
  for (int trial = 0; trial < 1000; ++trial) {
    const Mixture m = RandomMixture(trial, rng);
    const PowerMoments b = m.Powers();
    const PowerMomentsF bf = ToFloat(b);
    for (int s = 0; s < 8; ++s) {
      const float z_f = static_cast<float>(std::uniform_real_distribution<double>(-1, 1)(rng));
      if (m.DistanceTo(z_f) < 0.01) continue;
      EXPECT_NEAR(Hamburger4Occlusion(bf, z_f, kFloatMomentBias),
                  Hamburger4OcclusionReference(b, z_f, kFloatMomentBias), kFloatSlack)
          << trial << " " << z_f;
      EXPECT_NEAR(Hausdorff4Occlusion(bf, z_f, kFloatMomentBias),
                  Hausdorff4OcclusionReference(b, z_f, kFloatMomentBias), kFloatSlack)
          << trial << " " << z_f;
      EXPECT_NEAR(VarianceOcclusion(bf, z_f, kFloatMomentBias),
                  VarianceOcclusionReference(b, z_f, kFloatMomentBias), kFloatSlack);
    }
  }
}

TEST(PowerMomentBounds, NearSingularInputsStayFiniteAndInRange) {
  // A single depth, two depths 1e-6 apart, the ends of the range: Hankel matrices singular up
  // to rounding. Every query, including the depths themselves, gives a number in [0, 1].
  const std::vector<Mixture> cases = {
      {{0.25}, {1.0}},          {{-1.0}, {1.0}},          {{1.0}, {1.0}},
      {{0.3, 0.300001}, {0.5, 0.5}}, {{-1.0, 1.0}, {0.5, 0.5}}, {{0.0, 1e-7}, {0.9, 0.1}}};
  for (const Mixture& m : cases) {
    const PowerMomentsF bf = ToFloat(m.Powers());
    for (float z_f = -1.2f; z_f <= 1.2f; z_f += 0.01f) {
      for (const MomentBias& bias : {kFloatMomentBias, kQuantized16MomentBias}) {
        for (const float g : {Hamburger4Occlusion(bf, z_f, bias),
                              Hausdorff4Occlusion(bf, z_f, bias),
                              VarianceOcclusion(bf, z_f, bias)}) {
          ASSERT_GE(g, 0.0f) << m.z[0] << " " << z_f;
          ASSERT_LE(g, 1.0f) << m.z[0] << " " << z_f;
        }
      }
    }
  }
}

// ---- bad input -------------------------------------------------------------------------------

TEST(OcclusionFraction, MissingOrCorruptMomentsOccludeNothing) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<PowerMomentsF> bad = {{0, 0, 0, 0, 0},
                                          {-1, 0.1f, 0.2f, 0.0f, 0.1f},
                                          {1, nan, 0.2f, 0.0f, 0.1f},
                                          {1, 0.1f, inf, 0.0f, 0.1f},
                                          {nan, 0, 0, 0, 0}};
  for (const PowerMomentsF& b : bad) {
    for (const float z_f : {-0.5f, 0.5f, 1.0f}) {
      EXPECT_EQ(OcclusionFraction(b, z_f), 0.0f);
      EXPECT_EQ(Hausdorff4Occlusion(b, z_f, kFloatMomentBias), 0.0f);
      EXPECT_EQ(VarianceOcclusion(b, z_f, kFloatMomentBias), 0.0f);
    }
  }
}

TEST(OcclusionFraction, NaNQueryOccludesNothingAndFarQueriesAreClamped) {
  const Mixture m{{0.0}, {1.0}};
  const PowerMomentsF b = ToFloat(m.Powers());
  EXPECT_EQ(OcclusionFraction(b, std::numeric_limits<float>::quiet_NaN()), 0.0f);
  EXPECT_EQ(OcclusionFraction(b, -std::numeric_limits<float>::infinity()), 0.0f);
  const float behind = OcclusionFraction(b, std::numeric_limits<float>::infinity());
  EXPECT_EQ(behind, OcclusionFraction(b, static_cast<float>(kMaxQueryDepth)));
  EXPECT_GT(behind, 0.99f);
  EXPECT_EQ(Hamburger4OcclusionReference(m.Powers(), kNaN, kFloatMomentBias), 0.0);
}

TEST(OcclusionFraction, FilteredCoverageIsDividedOut) {
  // A texel half covered by valid depth (b_0 = 0.5 after filtering) answers like full coverage.
  const Mixture m{{-0.3, 0.4}, {0.5, 0.5}};
  PowerMoments half = m.Powers();
  for (double& v : half) v *= 0.5;
  EXPECT_NEAR(OcclusionFraction(ToFloat(half), 0.0f),
              OcclusionFraction(ToFloat(m.Powers()), 0.0f), 1e-6);
  EXPECT_NEAR(OcclusionFraction(ToFloat(half), 0.0f), 0.5,
              TwoSurfaceLeak(-0.3, 0.4, 0.0, kFloatMomentBias.alpha) + kFloatSlack);
}

// ---- batched queries ---------------------------------------------------------------------------

// OcclusionFractions evaluates the scalar function's float operations in the same order (select
// instead of branch), with FMA exactly where the scalar code calls std::fma, so the results are
// equal; the tolerance is one float ulp of a result in [0, 1], for a compiler that rounds the
// few remaining products differently (measured difference: 0).
constexpr float kBatchOcclusionTolerance = 6e-8f;

TEST(OcclusionFractions, AgreeWithTheScalarFunctionIncludingNearSingularAndBoundaryCases) {
  std::mt19937_64 rng(47);
  std::uniform_real_distribution<double> u(-1.2, 1.2), coverage(0.01, 1.0);
  std::vector<PowerMomentsF> moments;
  std::vector<float> z_f;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (int trial = 0; trial < 600; ++trial) {
    // RandomMixture: 1..8 surfaces, clusters 1e-4 wide and range ends (near-singular Hankel).
    const Mixture m = RandomMixture(trial, rng);
    PowerMoments b = m.Powers();
    if (trial % 3 == 0) {  // a filtered texel: part of the footprint covered
      const double c = coverage(rng);
      for (double& v : b) v *= c;
    }
    const PowerMomentsF bf = ToFloat(b);
    // Random queries, queries exactly at each surface and at its float neighbours (the bound's
    // steepest points), the ends of the range and beyond the clamp.
    std::vector<float> queries = {static_cast<float>(u(rng)), static_cast<float>(u(rng)),
                                  -1.0f, 1.0f, -5.0f, 5.0f, inf, -inf, nan};
    for (const double z : m.z) {
      const float zf = static_cast<float>(z);
      queries.insert(queries.end(), {zf, std::nextafter(zf, -inf), std::nextafter(zf, inf)});
    }
    for (const float q : queries) {
      moments.push_back(bf);
      z_f.push_back(q);
    }
  }
  // Degenerate texels: no coverage, negative coverage, NaN and infinite moments.
  for (const PowerMomentsF& bad : std::vector<PowerMomentsF>{{0, 0, 0, 0, 0},
                                                             {-1, 0.1f, 0.2f, 0.0f, 0.1f},
                                                             {1, nan, 0.2f, 0.0f, 0.1f},
                                                             {1, 0.1f, inf, 0.0f, 0.1f},
                                                             {1, 0.1f, 0.2f, 0.0f, -inf}}) {
    moments.push_back(bad);
    z_f.push_back(0.5f);
  }
  ASSERT_NE(moments.size() % 256, 0u);  // a partial last block
  for (const MomentBias& bias : {kFloatMomentBias, kQuantized16MomentBias}) {
    std::vector<float> batched(moments.size(), nan);
    OcclusionFractions(moments, z_f, batched, bias);
    float worst = 0.0f;
    for (size_t i = 0; i < moments.size(); ++i) {
      const float scalar = Hamburger4Occlusion(moments[i], z_f[i], bias);
      ASSERT_TRUE(batched[i] >= 0.0f && batched[i] <= 1.0f) << i << " " << batched[i];
      worst = std::max(worst, std::abs(batched[i] - scalar));
      EXPECT_NEAR(batched[i], scalar, kBatchOcclusionTolerance)
          << i << " z_f " << z_f[i] << " b " << moments[i][1] << " " << moments[i][2];
    }
    RecordProperty("worst_difference_alpha_" + std::to_string(bias.alpha), std::to_string(worst));
  }
}

TEST(OcclusionFractions, DefaultBiasIsOcclusionFractions) {
  const Mixture two{{-0.5, 0.5}, {0.3, 0.7}};
  const std::vector<PowerMomentsF> moments(3, ToFloat(two.Powers()));
  const std::vector<float> z_f = {-0.75f, 0.0f, 0.75f};
  std::vector<float> out(3);
  OcclusionFractions(moments, z_f, out);
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(out[i], OcclusionFraction(moments[i], z_f[i]));
  EXPECT_NEAR(out[1], 0.3, 3e-4 + kFloatSlack);
}

}  // namespace
}  // namespace transient

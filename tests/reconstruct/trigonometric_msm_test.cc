#include "transient/reconstruct/trigonometric_msm.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "tests/reconstruct/depth_mixture.h"
#include "transient/reconstruct/image.h"

namespace transient {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kAlpha64 = kTrigonometricBias64;
// The closed form is exact for the biased moments; the bias moves the answer by at most α
// (header), the remaining slack is rounding in the 3x3 solves with λ_min >= α (double).
constexpr double kReferenceSlack = 1e-6;
// Float path vs reference, measured below on random mixtures at α = 6e-5 (cond C <= 3/α = 5e4,
// float ε = 6e-8: ~3e-3 relative in C⁻¹, amplified where the case decision sits on a root).
constexpr double kFloatTolerance = 0.02;
// The bias is also light leaking: the bound of the biased moments may fall below the truth.
// Measured at queries >= 0.1 (normalised) from every surface, α = 6e-5: <= 5e-4 for one
// surface or two far apart, 1.1e-2 for surfaces 0.1 apart, 1.7e-2 for halves at both ends
// (they face each other across the seam at π); float within 1.5e-2 of the truth.
constexpr double kLightLeak = 0.02;
constexpr double kLightLeakFloat = 0.02;

using Mixture = testing::DepthMixture;  // tests/reconstruct/depth_mixture.h

TrigonometricMomentsF ToFloatMoments(const TrigonometricMoments& t) {
  TrigonometricMomentsF f;
  for (int j = 0; j < kTrigonometricMomentCount; ++j) f[j] = static_cast<float>(t[j]);
  return f;
}

// 1..6 surfaces; some at the ends of the range, some in clusters 1e-4 wide.
Mixture RandomMsmMixture(int trial, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> depth(-1.0, 1.0), weight(0.01, 1.0);
  Mixture m;
  const int count = 1 + trial % 6;
  for (int l = 0; l < count; ++l) {
    double z = depth(rng);
    if (l > 0 && trial % 5 == 0) z = m.z[0] + 1e-4 * depth(rng);
    if (trial % 7 == l) z = l % 2 == 0 ? -1.0 : 1.0;
    m.z.push_back(std::clamp(z, -1.0, 1.0));
    m.w.push_back(weight(rng));
  }
  double sum = 0.0;
  for (const double w : m.w) sum += w;
  for (double& w : m.w) w /= sum;
  return m;
}

TEST(TrigonometricMsm, DepthMapsToPhaseWithAGapAcrossPi) {
  const DepthNormalisation range{.near_m = 1.0, .far_m = 3.0};
  TrigonometricMoments t;
  EXPECT_EQ(DepthTrigonometricMoments(3.0, range, &t), DepthSample::kValid);
  const double far = kTrigonometricPhaseScale * M_PI;
  EXPECT_NEAR(t[1], std::cos(far), 1e-15);
  EXPECT_NEAR(t[2], std::sin(far), 1e-15);
  EXPECT_NEAR(t[4], std::sin(2.0 * far), 1e-15);
  EXPECT_EQ(DepthTrigonometricMoments(0.5, range, &t), DepthSample::kClamped);
  EXPECT_NEAR(t[2], std::sin(-far), 1e-15);  // clamped to near: φ = -κπ, not the seam
  EXPECT_LT(kTrigonometricPhaseScale, 1.0);
  EXPECT_EQ(DepthTrigonometricMoments(kNaN, range, &t), DepthSample::kInvalid);
  EXPECT_EQ(t, TrigonometricMoments{});
}

TEST(TrigonometricMsm, OneSurfaceGivesTheExactFractionUpToTheBias) {
  for (const double z : {-1.0, -0.6, 0.0, 0.3, 1.0}) {
    const Mixture m{{z}, {1.0}};
    for (const double z_f : {-1.0, -0.8, -0.2, 0.1, 0.5, 0.9, 1.0, 1.05}) {
      if (m.DistanceTo(z_f) < 0.1) continue;
      const double truth = m.FractionInFront(z_f);
      const double reference = TrigonometricOcclusionReference(m.Trigonometric(), z_f, kAlpha64);
      EXPECT_LE(reference, truth + kAlpha64) << "z = " << z << ", z_f = " << z_f;
      EXPECT_GE(reference, truth - kLightLeak) << "z = " << z << ", z_f = " << z_f;
      EXPECT_NEAR(TrigonometricOcclusion(ToFloatMoments(m.Trigonometric()), z_f, kAlpha64), truth,
                  kLightLeakFloat)
          << "z = " << z << ", z_f = " << z_f;
    }
  }
}

// Two surfaces make C(c) singular (thesis prop. 2.13): the boundary case, where the distribution
// is determined by its moments and the bound is exact.
TEST(TrigonometricMsm, TwoSurfacesGiveTheExactFractionUpToTheBias) {
  const std::vector<Mixture> mixtures = {
      {{-0.5, 0.5}, {0.3, 0.7}}, {{-1.0, 1.0}, {0.5, 0.5}}, {{0.1, 0.2}, {0.8, 0.2}},
      {{-0.9, 0.0}, {0.6, 0.4}}};
  for (const Mixture& m : mixtures) {
    for (double z_f = -1.0; z_f <= 1.1; z_f += 0.05) {
      if (m.DistanceTo(z_f) < 0.1) continue;
      const double truth = m.FractionInFront(z_f);
      const double reference = TrigonometricOcclusionReference(m.Trigonometric(), z_f, kAlpha64);
      EXPECT_LE(reference, truth + kAlpha64) << "z_f = " << z_f;
      EXPECT_GE(reference, truth - kLightLeak) << "z = (" << m.z[0] << ", " << m.z[1]
                                               << "), z_f = " << z_f;
      EXPECT_NEAR(TrigonometricOcclusion(ToFloatMoments(m.Trigonometric()), z_f, kAlpha64), truth,
                  kLightLeakFloat)
          << "z = (" << m.z[0] << ", " << m.z[1] << "), z_f = " << z_f;
    }
  }
}

TEST(TrigonometricMsm, BoundNeverExceedsTheTruthByMoreThanTheBias) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> query(-1.1, 1.1);
  for (int trial = 0; trial < 300; ++trial) {
    const Mixture m = RandomMsmMixture(trial, rng);
    const TrigonometricMoments t = m.Trigonometric();
    for (int k = 0; k < 8; ++k) {
      const double z_f = query(rng);
      const double bound = TrigonometricOcclusionReference(t, z_f, kAlpha64);
      EXPECT_LE(bound, m.FractionInFront(z_f) + kAlpha64 + kReferenceSlack)
          << "trial " << trial << ", z_f = " << z_f;
      EXPECT_GE(bound, 0.0);
    }
  }
}

// Where the closed form switches between its candidates the bound may dip by about 2α
// (measured 1.2e-4): below the sharp bound, so still a lower bound.
constexpr double kMonotoneSlack = 4 * kAlpha64;

TEST(TrigonometricMsm, BoundIsNonDecreasingUpToTheBiasInTheQueryDepth) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 60; ++trial) {
    const TrigonometricMoments t = RandomMsmMixture(trial, rng).Trigonometric();
    double previous = 0.0;
    for (double z_f = -1.1; z_f <= 1.1; z_f += 0.01) {
      const double bound = TrigonometricOcclusionReference(t, z_f, kAlpha64);
      EXPECT_GE(bound, previous - kMonotoneSlack) << "trial " << trial << ", z_f = " << z_f;
      previous = bound;
    }
  }
}

TEST(TrigonometricMsm, FloatAgreesWithTheReference) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> query(-1.1, 1.1);
  double worst = 0.0;
  for (int trial = 0; trial < 300; ++trial) {
    const Mixture m = RandomMsmMixture(trial, rng);
    const TrigonometricMoments t = m.Trigonometric();
    for (int k = 0; k < 8; ++k) {
      const double z_f = query(rng);
      if (m.DistanceTo(z_f) < 0.01) continue;  // the bound jumps at a surface
      const double reference = TrigonometricOcclusionReference(t, z_f, kAlpha64);
      const float single =
          TrigonometricOcclusion(ToFloatMoments(t), static_cast<float>(z_f), kAlpha64);
      worst = std::max(worst, std::abs(single - reference));
      EXPECT_NEAR(single, reference, kFloatTolerance) << "trial " << trial << ", z_f = " << z_f;
    }
  }
  RecordProperty("worst_float_error", std::to_string(worst));
}

TEST(TrigonometricMsm, NearSingularInputStaysFiniteAndInTheUnitInterval) {
  const std::vector<Mixture> mixtures = {
      {{0.25}, {1.0}}, {{0.25, 0.25 + 1e-7}, {0.5, 0.5}}, {{-1.0, -1.0 + 1e-6}, {0.9, 0.1}},
      {{1.0, 1.0 - 1e-9}, {0.2, 0.8}}};
  for (const Mixture& m : mixtures) {
    for (double z_f = -1.2; z_f <= 1.2; z_f += 0.01) {
      for (const double alpha : {0.0, kTrigonometricBias128, kAlpha64}) {
        const double reference = TrigonometricOcclusionReference(m.Trigonometric(), z_f, alpha);
        const float single = TrigonometricOcclusion(ToFloatMoments(m.Trigonometric()), z_f, alpha);
        EXPECT_TRUE(reference >= 0.0 && reference <= 1.0) << reference;
        EXPECT_TRUE(single >= 0.0f && single <= 1.0f) << single;
      }
    }
  }
}

TEST(TrigonometricMsm, InvalidInputGivesZeroNeverNaN) {
  const TrigonometricMoments valid = Mixture{{0.0}, {1.0}}.Trigonometric();
  EXPECT_EQ(TrigonometricOcclusionReference(valid, kNaN, kAlpha64), 0.0);
  EXPECT_EQ(TrigonometricOcclusion(ToFloatMoments(valid), NAN, kAlpha64), 0.0f);
  // Far behind the only surface the bound still saturates near 1, not NaN.
  EXPECT_GT(TrigonometricOcclusionReference(valid, kInfinity, kAlpha64), 0.99);
  for (int j = 0; j < kTrigonometricMomentCount; ++j) {
    TrigonometricMoments bad = valid;
    bad[j] = j % 2 == 0 ? kNaN : kInfinity;
    EXPECT_EQ(TrigonometricOcclusionReference(bad, 0.5, kAlpha64), 0.0) << j;
    EXPECT_EQ(TrigonometricOcclusion(ToFloatMoments(bad), 0.5f, kAlpha64), 0.0f) << j;
  }
  const TrigonometricMoments empty{};  // no valid depth in the footprint
  EXPECT_EQ(TrigonometricOcclusionReference(empty, 0.5, kAlpha64), 0.0);
  EXPECT_EQ(TrigonometricOcclusion(ToFloatMoments(empty), 0.5f, kAlpha64), 0.0f);
  // |c_1| > c_0 is no moment vector: C(c') is indefinite.
  const TrigonometricMoments impossible{1.0, 1.5, 0.0, 1.0, 0.0};
  EXPECT_EQ(TrigonometricOcclusionReference(impossible, 0.5, kAlpha64), 0.0);
  EXPECT_EQ(TrigonometricOcclusion(ToFloatMoments(impossible), 0.5f, kAlpha64), 0.0f);
}

TEST(TrigonometricMsm, CoverageBelowOneIsDividedOut) {
  const Mixture m{{-0.3, 0.6}, {0.5, 0.5}};
  TrigonometricMoments half = m.Trigonometric();
  for (double& v : half) v *= 0.5;
  EXPECT_NEAR(TrigonometricOcclusionReference(half, 0.2, kAlpha64),
              TrigonometricOcclusionReference(m.Trigonometric(), 0.2, kAlpha64), 1e-12);
}

}  // namespace
}  // namespace transient

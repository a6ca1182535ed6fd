#include "transient/reconstruct/biasing.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "test_measures.h"

namespace transient {
namespace {

constexpr double kEpsilon = 4e-3;
constexpr double kEigenTolerance = 1e-12;  // relative to c_0: a dense eigen-solve's accuracy

TEST(Biasing, RaisingZerothMomentReachesTheBound) {
  std::mt19937_64 rng(9);
  for (int m = 1; m <= kMaxOrder; ++m) {
    // An m-sparse measure has a singular C(c); noise that inflates c_1..c_m by 2 % makes it
    // indefinite (lambda_min = -0.02 c_0): exactly what biasing is for.
    const auto measure = testing::RandomSparseMeasure(m, 0.1, 0.0, rng);
    std::vector<Complex> c = measure.Moments(m);
    for (int j = 1; j <= m; ++j) c[j] *= 1.02;
    const std::vector<Complex> before = c;
    ASSERT_TRUE(Bias(c, kEpsilon, BiasMode::kRaiseZeroth));
    EXPECT_GT(c[0].real(), before[0].real());
    for (int j = 1; j <= m; ++j) EXPECT_EQ(c[j], before[j]);
    EXPECT_NEAR(SmallestEigenvalue(c), kEpsilon * c[0].real(), kEigenTolerance * c[0].real());
  }
}

TEST(Biasing, ScalingMomentsReachesTheBoundAndKeepsBrightness) {
  std::mt19937_64 rng(10);
  for (int m = 1; m <= kMaxOrder; ++m) {
    const auto measure = testing::RandomSparseMeasure(m, 0.1, 0.0, rng);
    std::vector<Complex> c = measure.Moments(m);
    const std::vector<Complex> before = c;
    ASSERT_TRUE(Bias(c, kEpsilon, BiasMode::kScaleMoments));
    EXPECT_EQ(c[0], before[0]);
    const Complex ratio = c[1] / before[1];
    EXPECT_LT(ratio.real(), 1.0);
    EXPECT_NEAR(ratio.imag(), 0.0, 1e-15);
    EXPECT_NEAR(SmallestEigenvalue(c), kEpsilon * c[0].real(), kEigenTolerance * c[0].real());
  }
}

TEST(Biasing, ValidMomentsAreLeftUnchanged) {
  std::mt19937_64 rng(11);
  for (int m = 1; m <= kMaxOrder; ++m) {
    const auto measure = testing::RandomSparseMeasure(m, 0.1, 0.5, rng);  // strong uniform part
    std::vector<Complex> c = measure.Moments(m);
    ASSERT_GE(SmallestEigenvalue(c), kEpsilon * c[0].real());
    const std::vector<Complex> before = c;
    EXPECT_FALSE(Bias(c, kEpsilon, BiasMode::kRaiseZeroth));
    EXPECT_FALSE(Bias(c, kEpsilon, BiasMode::kScaleMoments));
    EXPECT_EQ(c, before);
  }
}

TEST(Biasing, EstimatedZerothMomentPutsLambdaMinAtTheBound) {
  std::mt19937_64 rng(12);
  for (int m = 1; m <= kMaxOrder; ++m) {
    const auto measure = testing::RandomSparseMeasure(m, 0.1, 0.0, rng);
    std::vector<Complex> c = measure.Moments(m);
    c[0] = 0.0;
    c[0] = EstimateZerothMoment(c, kEpsilon);
    EXPECT_GT(c[0].real(), 0.0);
    EXPECT_NEAR(SmallestEigenvalue(c), kEpsilon * c[0].real(), kEigenTolerance * c[0].real());
    // An m-sparse measure has lambda_min = 0 at its true c_0, so the estimate is close to it.
    const double truth = measure.Moments(0)[0].real();
    EXPECT_NEAR(c[0].real(), truth / (1.0 - kEpsilon), 1e-9 * truth);
    // The estimate sits on the bound: biasing leaves it alone.
    EXPECT_FALSE(Bias(c, kEpsilon, BiasMode::kRaiseZeroth));
  }
}

TEST(Biasing, NothingToEstimateFromGivesZero) {
  const std::vector<Complex> c = {0.0, 0.0, 0.0};
  EXPECT_EQ(EstimateZerothMoment(c, kEpsilon), 0.0);
}

// SmallestEigenvalueZeroDiagonal takes Newton's steps on Levinson's recursion where c_0 > 0
// (ToeplitzLambdaMin) instead of the dense eigen-solve, which SmallestEigenvalue still runs:
// the two agree on moments inside, on and past the boundary of the moment set, for every order.
TEST(Biasing, ZeroDiagonalLambdaMinAgreesWithTheDenseEigenSolve) {
  std::mt19937_64 rng(12);
  int indefinite = 0, trials = 0;
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 40; ++trial) {
      double sigma = 0.0;
      const std::vector<Complex> c = testing::MomentSetTrial(m, m, trial, rng, &sigma);
      const double c0 = c[0].real();
      const double dense = std::min(0.0, SmallestEigenvalue(c) - c0);
      EXPECT_NEAR(SmallestEigenvalueZeroDiagonal(c), dense, 1e-11 * c0)
          << "m = " << m << ", trial " << trial;
      indefinite += SmallestEigenvalue(c) < 0.0;
      ++trials;
    }
  }
  EXPECT_GT(indefinite, trials / 4) << "the trials should reach past the moment set";
  // C(c) = c_0 I: lambda_min = c_0 with multiplicity m + 1 (bisection, not Newton, finds it).
  EXPECT_NEAR(SmallestEigenvalueZeroDiagonal(std::vector<Complex>{2.0, 0.0, 0.0, 0.0}), 0.0,
              1e-11 * 2.0);
}

TEST(Biasing, SmallestEigenvalueOfKnownMatrix) {
  // C = [[2, 1], [1, 2]] has eigenvalues 1 and 3.
  const std::vector<Complex> c = {2.0, 1.0};
  EXPECT_NEAR(SmallestEigenvalue(c), 1.0, 1e-15);
  EXPECT_NEAR(SmallestEigenvalueZeroDiagonal(c), -1.0, 1e-15);
}

}  // namespace
}  // namespace transient

#include "transient/reconstruct/levinson.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <complex>
#include <initializer_list>
#include <iostream>
#include <limits>
#include <random>

#include "test_measures.h"
#include "transient/reconstruct/biasing.h"

namespace transient {
namespace {

// Levinson is backward stable; with lambda_min >= 0.05 * c_0 the condition number stays
// below ~20 * (m+1), so a few hundred ulps bound the relative error.
constexpr double kSolveTolerance = 1e-11;

TEST(Levinson, AgreesWithDenseSolveOnRandomValidMoments) {
  std::mt19937_64 rng(1);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 20; ++trial) {
      const auto measure = testing::RandomSparseMeasure(1 + trial % (m + 2), 0.05, 0.3, rng);
      const std::vector<Complex> c = measure.Moments(m);
      std::vector<Complex> q(m + 1);
      ASSERT_TRUE(Levinson(c, q)) << "m = " << m;
      const ToeplitzMatrix t = MakeToeplitz(c);
      SmallVector e0 = SmallVector::Zero(m + 1);
      e0(0) = 1.0;
      const SmallVector expected = t.llt().solve(e0);
      for (int j = 0; j <= m; ++j) {
        EXPECT_NEAR(std::abs(q[j] - expected(j)), 0.0, kSolveTolerance * expected.norm())
            << "m = " << m << ", j = " << j;
      }
      EXPECT_EQ(q[0].imag(), 0.0);
      EXPECT_GT(q[0].real(), 0.0);
    }
  }
}

TEST(Levinson, InverseLevinsonReturnsTheInput) {
  std::mt19937_64 rng(2);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 10; ++trial) {
      const auto measure = testing::RandomSparseMeasure(m, 0.1, 0.2, rng);
      const std::vector<Complex> c = measure.Moments(m);
      std::vector<Complex> q(m + 1), back(m + 1);
      ASSERT_TRUE(Levinson(c, q));
      InverseLevinson(q, back);
      for (int j = 0; j <= m; ++j) {
        EXPECT_NEAR(std::abs(back[j] - c[j]), 0.0, 1e-10 * c[0].real()) << "m=" << m << " j=" << j;
      }
      // c_0 alone is InverseLevinson's c_0 to the last bit (the cumulative's Init uses it).
      EXPECT_EQ(InverseLevinsonZeroth(q), back[0].real()) << "m=" << m;
    }
  }
}

TEST(Levinson, RejectsAReflectionCoefficientOfMagnitudeOne) {
  // |c_1| = c_0: the 2x2 minor is singular (a single Dirac), not positive definite.
  const std::vector<Complex> c = {1.0, std::polar(1.0, 0.7)};
  std::vector<Complex> q(2);
  EXPECT_FALSE(Levinson(c, q));
}

TEST(Levinson, RejectsAnIndefiniteMatrixFoundLateInTheRecursion) {
  // The 2x2 minor is fine, but c_2 is inconsistent with any measure.
  const std::vector<Complex> c = {1.0, 0.5, Complex(-0.9, 0.0)};
  std::vector<Complex> q(3);
  EXPECT_FALSE(Levinson(c, q));
}

TEST(Levinson, RejectsNonPositiveAndNonFiniteZerothMoment) {
  std::vector<Complex> q(2);
  EXPECT_FALSE(Levinson(std::vector<Complex>{0.0, 0.0}, q));
  EXPECT_FALSE(Levinson(std::vector<Complex>{-1.0, 0.1}, q));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(Levinson(std::vector<Complex>{nan, 0.1}, q));
  EXPECT_FALSE(Levinson(std::vector<Complex>{1.0, Complex(nan, 0.0)}, q));
}

TEST(Levinson, UniformMeasureGivesAConstantPolynomial) {
  const std::vector<Complex> c = {2.0, 0.0, 0.0, 0.0};
  std::vector<Complex> q(4);
  ASSERT_TRUE(Levinson(c, q));
  EXPECT_DOUBLE_EQ(q[0].real(), 0.5);
  for (int j = 1; j < 4; ++j) EXPECT_EQ(q[j], Complex(0.0));
}

// lambda_min by Newton's steps on the shifted recursion, from both starts, against the dense
// eigen-solve (SmallestEigenvalue), on moments inside, on and past the moment set of every
// order (sparse measures, most with noise): where the result comes with an eigenvector-like q,
// it is lambda_min to 1e-11 c_0, and that is nearly always where noise makes lambda_min simple
// (without noise, fewer returns than m make lambda_min = 0 a repeated eigenvalue: declined).
TEST(ToeplitzLambdaMin, AgreesWithTheDenseEigenSolveFromBothStarts) {
  std::mt19937_64 rng(21);
  int trials = 0, noisy_trials = 0, failed_at_zero = 0;
  std::array<int, 2> vouched = {0, 0}, vouched_noisy = {0, 0};
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 40; ++trial) {
      double sigma = 0.0;
      const std::vector<Complex> c = testing::MomentSetTrial(m, 1 + trial % m, trial, rng, &sigma);
      const double dense = SmallestEigenvalue(c);
      std::vector<Complex> q(m + 1);
      failed_at_zero += ShiftedLevinson(c, 0.0, q) == LevinsonOutcome::kFailed;
      ++trials;
      noisy_trials += sigma > 0.0;
      for (int i = 0; i < 2; ++i) {
        const ToeplitzStart start =
            i == 0 ? ToeplitzStart::kGershgorin : ToeplitzStart::kSearchBelowZero;
        double lambda_min = 0.0;
        if (!ToeplitzLambdaMin(c, &lambda_min, q, start) || !LooksLikeLambdaMinEigenvector(q)) {
          continue;
        }
        ++vouched[i];
        vouched_noisy[i] += sigma > 0.0;
        EXPECT_NEAR(lambda_min, dense, 1e-11 * c[0].real())
            << "m = " << m << ", trial " << trial << ", start " << i;
      }
    }
  }
  // The starts below 0 are exercised: the recursion fails at 0 for many of these moments.
  EXPECT_GT(failed_at_zero, trials / 4);
  EXPECT_GT(vouched_noisy[0], 0.95 * noisy_trials);
  EXPECT_GT(vouched_noisy[1], 0.95 * noisy_trials);
  std::cout << "vouched for " << vouched[0] << " (Gershgorin's start) and " << vouched[1]
            << " (the search below 0) of " << trials << " (with noise: " << vouched_noisy[0]
            << " and " << vouched_noisy[1] << " of " << noisy_trials
            << "); the recursion failed at 0 for " << failed_at_zero << "\n";
}

TEST(ToeplitzLambdaMin, RationalStepLandsOnItsModelsPoleFromEitherSide) {
  // q_0 = b + a / (mu - lambda): RationalStep from lambda, with the iterate before at `before`,
  // reaches mu, where Newton's step (exact only for b = 0) falls short or overshoots.
  const double a = 0.3, b = 2.0, mu = -0.01;
  const auto q0 = [&](double lambda) { return b + a / (mu - lambda); };
  const auto slope = [&](double lambda) { return a / ((mu - lambda) * (mu - lambda)); };
  const std::pair<double, double> iterates[] = {
      {-0.05, -0.03},  // both below mu
      {0.004, 0.001},  // both above (where q_0 < 0)
      {-0.03, 0.001},  // one on each side
  };
  for (const auto& [before, lambda] : iterates) {
    const double newton = q0(lambda) / slope(lambda);
    const double step =
        RationalStep(newton, lambda - before, q0(lambda) - q0(before), slope(lambda));
    EXPECT_NEAR(lambda + step, mu, 1e-15) << "from " << before << " and " << lambda;
    EXPECT_GT(std::abs(lambda + newton - mu), 1e-4)
        << "Newton's step alone lands near mu: the case cannot tell";
  }
  // Where the model has no finite step, or one the other way, Newton's.
  EXPECT_EQ(RationalStep(0.01, 0.1, 0.2, 2.0), 0.01);    // |q|^2 h = rise: no finite model
  EXPECT_EQ(RationalStep(0.01, 0.1, 0.3, 2.0), 0.01);    // the model steps back
  EXPECT_EQ(RationalStep(-0.01, 0.1, 0.1, 2.0), -0.01);  // the model's 0.1 goes the other way
}

TEST(ToeplitzLambdaMin, DeclinesWhatItCannotStartFrom) {
  std::vector<Complex> q(3);
  double lambda_min = 0.0;
  EXPECT_FALSE(ToeplitzLambdaMin(std::vector<Complex>{0.0, 0.5, 0.1}, &lambda_min, q));
  EXPECT_FALSE(ToeplitzLambdaMin(std::vector<Complex>{-1.0, 0.5, 0.1}, &lambda_min, q));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(ToeplitzLambdaMin(std::vector<Complex>{nan, 0.5, 0.1}, &lambda_min, q,
                                 ToeplitzStart::kSearchBelowZero));
}

TEST(ToeplitzLambdaMin, EndsForASubnormalZerothMoment) {
  // The search's first shift, -c_0 / 64, rounds to -0 here, which growing fourfold would not
  // move (this test then hangs): it must go on from Gershgorin's bound. C(c) is about
  // [[0, 1, 1], [1, 0, 1], [1, 1, 0]], whose lambda_min is -1.
  const std::vector<Complex> c = {4.9e-324, 1.0, 1.0};
  std::vector<Complex> q(3);
  double lambda_min = 0.0;
  if (ToeplitzLambdaMin(c, &lambda_min, q, ToeplitzStart::kSearchBelowZero)) {
    EXPECT_NEAR(lambda_min, SmallestEigenvalue(c), 1e-9);
  }
  EXPECT_NEAR(SmallestEigenvalueZeroDiagonal(c), -1.0, 1e-9);
}

// Moments far past the moment set, c_0 a thousandth or less of |c_j| (found by a search over
// random vectors; SolveLanes.* in kernels_test.cc runs more of them through the solve's lanes).
// With c_0 ~ 1e-4 the search below zero ends on a collapsed bracket: Newton's step leaves a
// bracket narrower than the tolerance, whose middle is lambda_min. With c_0 ~ 1e-6 the
// tolerance, kToeplitzLambdaTolerance c_0 ~ 1e-18, is below the rounding of lambda_min ~ -1:
// the steps never get under it, and ToeplitzLambdaMin declines after kToeplitzLambdaMaxSteps
// recursions (biasing then takes the dense eigen-solve) instead of looping on.
TEST(ToeplitzLambdaMin, EndsOnACollapsedBracketOrAtItsStepLimit) {
  // Floats, as the search found them (the same values rounded otherwise end differently).
  const auto from_floats = [](std::initializer_list<std::complex<float>> c) {
    return std::vector<Complex>(c.begin(), c.end());
  };
  const std::vector<Complex> collapsed = from_floats({0.000125718303f,
                                                      {0.269875675f, 0.00324794254f},
                                                      {0.122146212f, 0.118517525f},
                                                      {-0.458267599f, 0.467290074f}});
  const std::vector<Complex> step_limit = from_floats({1.27122507e-06f,
                                                       {-0.159219727f, -0.417188078f},
                                                       {-0.463278025f, 0.0642449409f},
                                                       {0.312678397f, 0.486924499f}});
  std::vector<Complex> q(4);
  double lambda_min = 0.0;
  ASSERT_TRUE(ToeplitzLambdaMin(collapsed, &lambda_min, q, ToeplitzStart::kSearchBelowZero));
  EXPECT_TRUE(LooksLikeLambdaMinEigenvector(q));
  EXPECT_NEAR(lambda_min, SmallestEigenvalue(collapsed), 1e-12);
  EXPECT_LT(lambda_min, -0.5);
  EXPECT_FALSE(ToeplitzLambdaMin(step_limit, &lambda_min, q, ToeplitzStart::kSearchBelowZero));
  EXPECT_NEAR(SmallestEigenvalueZeroDiagonal(step_limit),
              SmallestEigenvalue(step_limit) - step_limit[0].real(), 1e-12);
}

TEST(ToeplitzLambdaMin, DeclinesWhereGershgorinsBoundOverflows) {
  // |c_1|^2 overflows, and so does the bound (levinson.h): from either start the steps decline
  // at once (the search below zero would otherwise run until its shift overflowed, ~180
  // recursions), and the dense eigen-solve gives biasing its value.
  const std::vector<Complex> c = {1e160, Complex(1.2e160, 0.3e160), Complex(0.2e160, -0.7e160)};
  std::vector<Complex> q(3);
  double lambda_min = 0.0;
  EXPECT_FALSE(ToeplitzLambdaMin(c, &lambda_min, q, ToeplitzStart::kGershgorin));
  EXPECT_FALSE(ToeplitzLambdaMin(c, &lambda_min, q, ToeplitzStart::kSearchBelowZero));
  const double expected = SmallestEigenvalue(c) - c[0].real();
  EXPECT_NEAR(SmallestEigenvalueZeroDiagonal(c), expected, 1e-12 * 1e160);
  EXPECT_LT(SmallestEigenvalueZeroDiagonal(c), -1e160);
}

}  // namespace
}  // namespace transient

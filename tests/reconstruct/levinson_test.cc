#include "transient/reconstruct/levinson.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <limits>
#include <random>

#include "test_measures.h"

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

}  // namespace
}  // namespace transient

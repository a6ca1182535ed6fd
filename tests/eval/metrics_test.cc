// Earth mover's distance on the circle and error summaries on known answers.
#include "tools/eval/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace transient::eval {
namespace {

constexpr double kT = 43.48;  // a period, in any unit (ns here)
// Step functions are integrated exactly; only summation rounding remains.
constexpr double kExact = 1e-12;

CircleCumulative Dirac(double position, double weight = 1.0) {
  return {[=](double tau) { return tau > position ? weight : 0.0; }, {position}};
}

CircleCumulative Uniform(double mass) {
  return {[=](double tau) { return mass * tau / kT; }, {}};
}

TEST(CircleEmd, IdenticalDistributionsAreZeroApart) {
  EXPECT_NEAR(CircleEmd(Dirac(10.0), Dirac(10.0), kT, 64), 0.0, kExact);
  EXPECT_NEAR(CircleEmd(Uniform(2.0), Uniform(2.0), kT, 64), 0.0, kExact);
}

TEST(CircleEmd, DiracMovedByDIsDTimesItsWeightApart) {
  for (double d : {0.01, 0.37, 5.0, 20.0}) {
    EXPECT_NEAR(CircleEmd(Dirac(10.0 + d, 2.0), Dirac(10.0, 2.0), kT, 64), 2.0 * d, kExact) << d;
  }
}

TEST(CircleEmd, GoesTheShortWayRoundTheCircle) {
  // Diracs at 1 and T - 1 are 2 apart on the circle, not T - 2: the free constant alpha.
  EXPECT_NEAR(CircleEmd(Dirac(1.0), Dirac(kT - 1.0), kT, 64), 2.0, kExact);
  // Half a period is the farthest apart two points can be.
  EXPECT_NEAR(CircleEmd(Dirac(3.0), Dirac(3.0 + 0.5 * kT), kT, 64), 0.5 * kT, kExact);
}

TEST(CircleEmd, UniformLightToOnePointCostsAQuarterPeriod) {
  // Mean distance from a point to uniform light on a circle of length T is T/4. The integral
  // of a linear difference is exact by the midpoint rule, but the median is taken among cell
  // midpoints: off by up to h/(2T) of the light, which costs O(h^2/T).
  constexpr int kBins = 256;
  constexpr double h = kT / kBins;
  EXPECT_NEAR(CircleEmd(Uniform(1.0), Dirac(7.0), kT, kBins), 0.25 * kT, h * h / kT);
}

TEST(CircleEmd, SplitDiracKnownAnswer) {
  // Half the light moves by 2 and half by 4 (two directions): 0.5*2 + 0.5*4 = 3.
  const CircleCumulative split{
      [](double tau) { return (tau > 8.0 ? 0.5 : 0.0) + (tau > 14.0 ? 0.5 : 0.0); }, {8.0, 14.0}};
  EXPECT_NEAR(CircleEmd(split, Dirac(10.0), kT, 64), 3.0, kExact);
}

TEST(WrapSymmetric, WrapsIntoHalfPeriods) {
  EXPECT_DOUBLE_EQ(WrapSymmetric(0.3, 10.0), 0.3);
  EXPECT_NEAR(WrapSymmetric(9.7, 10.0), -0.3, 1e-15);
  EXPECT_NEAR(WrapSymmetric(-9.7, 10.0), 0.3, 1e-15);
  EXPECT_DOUBLE_EQ(WrapSymmetric(25.0, 10.0), -5.0);  // [-P/2, P/2)
}

TEST(SummarizeErrors, KnownMeanRmseAndPercentile) {
  std::vector<double> errors;
  for (int i = 1; i <= 20; ++i) errors.push_back(i % 2 == 0 ? i : -i);  // -1, 2, -3, ..., 20
  const ErrorSummary summary = SummarizeErrors(errors);
  EXPECT_EQ(summary.count, 20);
  EXPECT_DOUBLE_EQ(summary.mean, 0.5);                    // ten pairs (-odd, +even) of +1
  EXPECT_NEAR(summary.rmse, std::sqrt(2870.0 / 20), 1e-12);  // sum of squares 1..20 = 2870
  EXPECT_DOUBLE_EQ(summary.p95_abs, 19.05);  // type 7: position 0.95 * 19 = 18.05 -> 19 + 0.05
  EXPECT_EQ(summary.within_10, 10);          // -1, 2, ..., 10: |e| <= 10 counts, 11 does not
}

TEST(SummarizeErrors, NothingToSummarizeIsNaN) {
  const ErrorSummary summary = SummarizeErrors({});
  EXPECT_EQ(summary.count, 0);
  EXPECT_TRUE(std::isnan(summary.rmse));
}

}  // namespace
}  // namespace transient::eval

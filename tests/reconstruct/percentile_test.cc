// The project's one percentile against numpy's default (linear, type 7) on known answers.
#include "transient/reconstruct/percentile.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

namespace transient {
namespace {

constexpr double kTolerance = 1e-12;  // a few ulps of values near 10

TEST(Percentile, InterpolatesLinearlyBetweenClosestRanksLikeNumpy) {
  // numpy.percentile([3, 1, 4, 1.5, 9, 2.6], q) for these q.
  const std::vector<double> values = {3, 1, 4, 1.5, 9, 2.6};
  const std::pair<double, double> expected[] = {
      {0.0, 1.0}, {20.0, 1.5}, {50.0, 2.8}, {90.0, 6.5}, {99.0, 8.75}, {100.0, 9.0}};
  for (const auto& [percent, answer] : expected) {
    std::vector<double> copy = values;
    EXPECT_NEAR(Percentile(std::span<double>(copy), percent), answer, kTolerance) << percent;
  }
}

TEST(Percentile, SingleValueIsEveryPercentileAndNoValuesIsNan) {
  std::vector<double> one = {7.5};
  EXPECT_EQ(Percentile(std::span<double>(one), 0.0), 7.5);
  EXPECT_EQ(Percentile(std::span<double>(one), 99.5), 7.5);
  std::vector<double> none;
  EXPECT_TRUE(std::isnan(Percentile(std::span<double>(none), 50.0)));
}

TEST(Percentile, FloatsOfAThousandShuffledValuesGiveTheRankedValue) {
  std::vector<float> values(1000);
  std::iota(values.begin(), values.end(), 0.0f);
  std::shuffle(values.begin(), values.end(), std::mt19937(7));
  EXPECT_NEAR(Percentile(std::span<float>(values), 99.5), 994.005, 1e-9);
  EXPECT_NEAR(Percentile(std::span<float>(values), 50.0), 499.5, 1e-9);
}

TEST(Percentile, PercentsOutsideZeroToHundredAreClamped) {
  std::vector<double> values = {2.0, 1.0, 3.0};
  EXPECT_EQ(Percentile(std::span<double>(values), -5.0), 1.0);
  EXPECT_EQ(Percentile(std::span<double>(values), 250.0), 3.0);
}

TEST(Percentile, MedianOfAnEvenCountIsTheMeanOfTheMiddleValuesEvenWhenInfinite) {
  // The demodulator's robust scores are medians of ratios that may be infinite (a score over a
  // zero scale): two infinite middle values give infinity, not inf - inf = NaN.
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> values = {4.0, 1.0, 3.0, 2.0};
  EXPECT_EQ(Percentile(std::span<double>(values), 50.0), 2.5);
  values = {inf, 1.0, inf, inf};
  EXPECT_EQ(Percentile(std::span<double>(values), 50.0), inf);
  values = {inf, 1.0, 2.0, inf};
  EXPECT_EQ(Percentile(std::span<double>(values), 50.0), inf);
}

}  // namespace
}  // namespace transient

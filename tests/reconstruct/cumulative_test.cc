#include "transient/reconstruct/cumulative.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "test_measures.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/mese.h"

namespace transient {
namespace {

constexpr double kCumulativeTolerance = 1e-8;  // relative to c_0
constexpr int kSamplesPerUnit = 1 << 17;  // resolves peaks ~1e-4 rad wide (eps = 0.02, m = 16)

TEST(Cumulative, MatchesNumericalIntegrationAndEndsAtZerothMoment) {
  std::mt19937_64 rng(18);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 3; ++trial) {
      const auto measure = testing::RandomSparseMeasure(1 + rng() % (m + 1), 0.05, 0.0, rng);
      std::vector<Complex> c = measure.Moments(m);
      Bias(c, 0.02, BiasMode::kRaiseZeroth);
      std::vector<Complex> q(m + 1);
      ASSERT_TRUE(Levinson(c, q));
      MeseCumulative cumulative;
      ASSERT_TRUE(cumulative.Init(q));
      const double c0 = c[0].real();
      EXPECT_NEAR(cumulative(0.0), 0.0, kCumulativeTolerance * c0);
      EXPECT_NEAR(cumulative(kTwoPi), c0, kCumulativeTolerance * c0) << "m = " << m;
      // Composite Simpson from 0 to each checkpoint.
      const int samples = kSamplesPerUnit;
      const double h = kTwoPi / samples;
      double integral = 0.0, previous = 0.0;
      for (int k = 0; k < samples; ++k) {
        const double a = k * h;
        integral += h / 6.0 *
                    (MeseDensity(q, a) + 4.0 * MeseDensity(q, a + h / 2) + MeseDensity(q, a + h));
        if ((k + 1) % (samples / 16) == 0) {
          const double value = cumulative((k + 1) * h);
          EXPECT_NEAR(value, integral, kCumulativeTolerance * c0) << "m=" << m << " k=" << k;
          EXPECT_GE(value, previous - kCumulativeTolerance * c0);  // non-decreasing
          previous = value;
        }
      }
    }
  }
}

TEST(Cumulative, UniformDensityIsLinear) {
  const std::vector<Complex> c = {3.0, 0.0, 0.0};
  std::vector<Complex> q(3);
  ASSERT_TRUE(Levinson(c, q));
  MeseCumulative cumulative;
  ASSERT_TRUE(cumulative.Init(q));
  EXPECT_NEAR(cumulative(std::numbers::pi), 1.5, 1e-14);
  EXPECT_NEAR(cumulative(kTwoPi), 3.0, 1e-14);
}

}  // namespace
}  // namespace transient

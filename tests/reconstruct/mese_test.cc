#include "transient/reconstruct/mese.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "test_measures.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/levinson.h"

namespace transient {
namespace {

// The trapezoidal rule is exponentially accurate for smooth periodic functions; with
// lambda_min >= 0.02 c_0 the density's peaks are wide enough for 2^15 samples to resolve
// them far below this (a peak of width 1e-4 rad needs ~1e5 samples).
constexpr double kMomentTolerance = 1e-6;
constexpr int kIntegrationSamples = 1 << 18;

std::vector<Complex> RandomValidMoments(int m, std::mt19937_64& rng) {
  const auto measure = testing::RandomSparseMeasure(1 + rng() % (m + 2), 0.05, 0.0, rng);
  std::vector<Complex> c = measure.Moments(m);
  Bias(c, 0.02, BiasMode::kRaiseZeroth);
  return c;
}

TEST(Mese, DensityReproducesInputMoments) {
  std::mt19937_64 rng(4);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 4; ++trial) {
      const std::vector<Complex> c = RandomValidMoments(m, rng);
      std::vector<Complex> q(m + 1);
      ASSERT_TRUE(Levinson(c, q));
      const std::vector<Complex> reproduced = testing::DensityMoments(
          [&](double phi) { return MeseDensity(q, phi); }, m, kIntegrationSamples);
      for (int j = 0; j <= m; ++j) {
        EXPECT_LE(std::abs(reproduced[j] - c[j]), kMomentTolerance * c[0].real())
            << "m = " << m << ", j = " << j;
      }
    }
  }
}

TEST(Mese, DensityIsPositive) {
  std::mt19937_64 rng(5);
  for (int m = 1; m <= kMaxOrder; m += 3) {
    const std::vector<Complex> c = RandomValidMoments(m, rng);
    std::vector<Complex> q(m + 1);
    ASSERT_TRUE(Levinson(c, q));
    for (int n = 0; n < 1000; ++n) EXPECT_GT(MeseDensity(q, kTwoPi * n / 1000), 0.0);
  }
}

TEST(Mese, RootsLieOutsideTheUnitCircle) {  // thesis lemma B.9
  std::mt19937_64 rng(6);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 10; ++trial) {
      const std::vector<Complex> c = RandomValidMoments(m, rng);
      std::vector<Complex> q(m + 1), roots(m);
      ASSERT_TRUE(Levinson(c, q));
      const int count = MeseRoots(q, roots);
      EXPECT_EQ(count, m);
      for (int l = 0; l < count; ++l) EXPECT_GT(std::abs(roots[l]), 1.0) << "m = " << m;
    }
  }
}

TEST(Mese, DensityIsProportionalToTheRootProduct) {  // thesis eq. 8.6
  std::mt19937_64 rng(7);
  const int m = 5;
  const std::vector<Complex> c = RandomValidMoments(m, rng);
  std::vector<Complex> q(m + 1), roots(m);
  ASSERT_TRUE(Levinson(c, q));
  ASSERT_EQ(MeseRoots(q, roots), m);
  auto product = [&](double phi) {
    double p = 1.0;
    for (const Complex& x : roots) p /= std::norm(std::polar(1.0, phi) - x);
    return p;
  };
  const double ratio = MeseDensity(q, 0.3) / product(0.3);
  for (double phi : {1.0, 2.5, 4.0, 6.0}) {
    EXPECT_NEAR(MeseDensity(q, phi) / product(phi), ratio, 1e-9 * ratio);
  }
}

TEST(Mese, DenominatorSeriesMatchesDirectEvaluationAndItsDerivatives) {
  std::mt19937_64 rng(8);
  const int m = 7;
  const std::vector<Complex> c = RandomValidMoments(m, rng);
  std::vector<Complex> q(m + 1), a(m + 1);
  ASSERT_TRUE(Levinson(c, q));
  MeseDenominatorSeries(q, a);
  const double h = 1e-5;
  for (double phi : {0.0, 0.9, 3.1, 5.5}) {
    const SeriesValue s = EvaluateDenominatorSeries(a, phi);
    const double direct = q[0].real() / (kTwoPi * MeseDensity(q, phi));
    EXPECT_NEAR(s.value, direct, 1e-10 * direct);
    const double plus = EvaluateDenominatorSeries(a, phi + h).value;
    const double minus = EvaluateDenominatorSeries(a, phi - h).value;
    EXPECT_NEAR(s.first, (plus - minus) / (2 * h), 1e-5 * (1 + std::abs(s.first)));
    EXPECT_NEAR(s.second, (plus - 2 * s.value + minus) / (h * h), 1e-3 * (1 + std::abs(s.second)));
  }
}

}  // namespace
}  // namespace transient

#include "transient/reconstruct/mese.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "test_measures.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/levinson.h"

namespace transient {
namespace {

// The trapezoidal rule is exponentially accurate for smooth periodic functions once the grid
// resolves the sharpest peak: at eps = 4e-3 and m = 16 roots come within ~1e-5 of the unit
// circle, where 2^18 samples still miss by ~1e-3 and 2^20 reach ~1e-12.
constexpr double kMomentTolerance = 1e-6;
constexpr int kIntegrationSamples = 1 << 20;
constexpr double kEpsilon = 4e-3;  // thesis §8.5

std::vector<Complex> RandomValidMoments(int m, std::mt19937_64& rng) {
  const auto measure = testing::RandomSparseMeasure(1 + rng() % (m + 2), 0.05, 0.0, rng);
  std::vector<Complex> c = measure.Moments(m);
  Bias(c, kEpsilon, BiasMode::kRaiseZeroth);
  return c;
}

TEST(Mese, DensityReproducesInputMoments) {
  std::mt19937_64 rng(4);
  for (int m : {1, 2, 3, 4, 6, 8, 12, 16}) {
    for (int trial = 0; trial < 2; ++trial) {
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

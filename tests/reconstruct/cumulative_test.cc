#include "transient/reconstruct/cumulative.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "test_measures.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/quadrature.h"

namespace transient {
namespace {

constexpr double kCumulativeTolerance = 1e-8;  // relative to c_0
constexpr double kSharpestEpsilon = 4e-3;      // thesis §8.5: the sharpest peaks we produce

std::vector<double> UniformPhasesForTest(int count) {  // 0 .. 2 pi, both ends
  std::vector<double> phases(count);
  for (int n = 0; n < count; ++n) phases[n] = kTwoPi * n / (count - 1);
  return phases;
}

double Integral(std::span<const Complex> q, double a, double b, double c0) {
  return IntegrateAdaptive([&](double phi) { return MeseDensity(q, phi); }, a, b, 1e-10 * c0);
}

TEST(Quadrature, IntegratesKnownFunctions) {
  EXPECT_NEAR(IntegrateAdaptive([](double x) { return std::sin(x); }, 0.0, std::numbers::pi, 1e-12),
              2.0, 1e-11);
  // A Lorentzian of width 1e-6: a fixed grid of 64 pieces cannot see it, the adaptive rule can.
  const double w = 1e-6;
  auto lorentzian = [&](double x) { return w / ((x - 0.3) * (x - 0.3) + w * w); };
  EXPECT_NEAR(IntegrateAdaptive(lorentzian, 0.0, 1.0, 1e-9),
              std::atan(0.7 / w) + std::atan(0.3 / w), 1e-6);
}

TEST(Cumulative, MatchesNumericalIntegrationAndEndsAtZerothMoment) {
  std::mt19937_64 rng(18);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 3; ++trial) {
      const auto measure = testing::RandomSparseMeasure(1 + rng() % (m + 1), 0.05, 0.0, rng);
      std::vector<Complex> c = measure.Moments(m);
      Bias(c, kSharpestEpsilon, BiasMode::kRaiseZeroth);
      std::vector<Complex> q(m + 1);
      ASSERT_TRUE(Levinson(c, q));
      MeseCumulative cumulative;
      ASSERT_TRUE(cumulative.Init(q));
      EXPECT_TRUE(cumulative.closed_form());
      const double c0 = c[0].real();
      EXPECT_NEAR(cumulative(0.0), 0.0, kCumulativeTolerance * c0);
      EXPECT_NEAR(cumulative(kTwoPi), c0, kCumulativeTolerance * c0) << "m = " << m;
      double integral = 0.0, previous = 0.0;
      const int checkpoints = 16;
      for (int k = 1; k <= checkpoints; ++k) {
        const double a = kTwoPi * (k - 1) / checkpoints, b = kTwoPi * k / checkpoints;
        integral += Integral(q, a, b, c0);
        const double value = cumulative(b);
        EXPECT_NEAR(value, integral, kCumulativeTolerance * c0) << "m=" << m << " k=" << k;
        EXPECT_GE(value, previous - kCumulativeTolerance * c0);  // non-decreasing
        previous = value;
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

TEST(Cumulative, CoincidentRootsFallBackToQuadrature) {
  // p(x) = (x - a)^2 (x - b) with roots outside the circle is a valid MESE polynomial
  // (thesis lemma B.10: q <-> c is a bijection); its double root breaks partial fractions.
  const Complex a = std::polar(1.3, 1.0), b = std::polar(1.8, 4.0);
  std::vector<Complex> p = {-a * a * b, a * a + 2.0 * a * b, -(2.0 * a + b), 1.0};
  const Complex normalise = std::abs(p[0]) / p[0];  // make p(0) = conj(q_0) real positive
  std::vector<Complex> q(4);
  for (int j = 0; j < 4; ++j) q[j] = std::conj(p[j] * normalise);
  std::vector<Complex> c(4);
  InverseLevinson(q, c);
  MeseCumulative cumulative;
  ASSERT_TRUE(cumulative.Init(q));
  EXPECT_FALSE(cumulative.closed_form());
  const double c0 = c[0].real();
  EXPECT_NEAR(cumulative(kTwoPi), c0, 1e-8 * c0);
  EXPECT_NEAR(cumulative(2.0), Integral(q, 0.0, 2.0, c0), 1e-8 * c0);
}

// Evaluate (the optimized kernels' route: real log and atan from tabled cosines) against
// operator() (glibc's complex Log) at the sharpest peaks biasing leaves, on every order, and
// on the quadrature fallback. Float output: equal to the float's rounding of c_0-sized values.
TEST(Cumulative, EvaluateMatchesTheReferenceAtSharpPeaksAndOnQuadrature) {
  std::mt19937_64 rng(19);
  const std::vector<double> phases = UniformPhasesForTest(257);
  std::vector<double> cosines, sines;
  for (double phi : phases) {
    cosines.push_back(std::cos(phi));
    sines.push_back(std::sin(phi));
  }
  std::vector<float> got(2 * phases.size());
  for (int m = 1; m <= kMaxOrder; ++m) {
    const auto measure = testing::RandomSparseMeasure(1 + rng() % (m + 1), 0.05, 0.0, rng);
    std::vector<Complex> c = measure.Moments(m);
    Bias(c, kSharpestEpsilon, BiasMode::kRaiseZeroth);
    std::vector<Complex> q(m + 1);
    ASSERT_TRUE(Levinson(c, q));
    MeseCumulative cumulative;
    ASSERT_TRUE(cumulative.Init(q));
    ASSERT_TRUE(cumulative.closed_form());
    cumulative.Evaluate(phases, cosines, sines, got.data(), 2);  // every other entry: stride
    for (size_t n = 0; n < phases.size(); ++n) {
      const double expected = cumulative(phases[n]);
      EXPECT_NEAR(got[2 * n], expected, 1e-6 * c[0].real()) << "m = " << m << " n = " << n;
    }
  }
  // The double root of CoincidentRootsFallBackToQuadrature: Evaluate integrates as well.
  const Complex a = std::polar(1.3, 1.0), b = std::polar(1.8, 4.0);
  std::vector<Complex> p = {-a * a * b, a * a + 2.0 * a * b, -(2.0 * a + b), 1.0};
  const Complex normalise = std::abs(p[0]) / p[0];
  std::vector<Complex> q(4);
  for (int j = 0; j < 4; ++j) q[j] = std::conj(p[j] * normalise);
  MeseCumulative cumulative;
  ASSERT_TRUE(cumulative.Init(q));
  ASSERT_FALSE(cumulative.closed_form());
  cumulative.Evaluate(phases, cosines, sines, got.data(), 1);
  for (size_t n = 0; n < phases.size(); n += 16) {
    EXPECT_EQ(got[n], static_cast<float>(cumulative(phases[n]))) << n;
  }
}

TEST(Cumulative, RejectsInvalidCoefficients) {
  MeseCumulative cumulative;
  EXPECT_FALSE(cumulative.Init(std::vector<Complex>{0.0, 0.1}));
  EXPECT_FALSE(cumulative.Init(std::vector<Complex>{std::nan(""), 0.1}));
}

}  // namespace
}  // namespace transient

// Ground truths of the benchmark: closed forms against numerical integration and against the
// numeric core's Dirac moments and the simulator's own ground truth.
#include "tools/eval/ground_truth.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "transient/drivers/capture_source.h"
#include "transient/drivers/simulator.h"
#include "transient/reconstruct/moments.h"

namespace transient::eval {
namespace {

// Composite Simpson rule with n (even) panels.
template <typename F>
auto Simpson(F f, double a, double b, int n) {
  const double h = (b - a) / n;
  auto sum = f(a) + f(b);
  for (int i = 1; i < n; ++i) sum += (i % 2 == 1 ? 4.0 : 2.0) * f(a + i * h);
  return sum * (h / 3.0);
}

// EMGs from sharp (short tail) to long-tailed, and the two degenerate shapes.
std::vector<Return> TestReturns() {
  return {
      {10e-9, 1.0, 0.5e-9, 1.0 / 2e-9},   // the benchmark's typical continuous return
      {5e-9, 1.0, 0.8e-9, 1.0 / 0.05e-9},  // rate*sigma = 16: near-Gaussian, large exponent
      {5e-9, 1.0, 0.3e-9, 1.0 / 6e-9},    // long tail
      {5e-9, 1.0, 0.4e-9, 0.0},           // Gaussian only
      {5e-9, 1.0, 0.0, 1.0 / 2e-9},       // exponential only
  };
}

TEST(ReturnCdf, EqualsTheIntegralOfTheDensity) {
  // Simpson with 20000 panels over ~60 ns: error ~ h^4 f'''' below 1e-10 for sigma >= 0.3 ns.
  constexpr double kTolerance = 1e-8;
  for (const Return& r : TestReturns()) {
    const double start = r.tau_s - 12.0 * r.sigma_s;
    for (double t : {r.tau_s - r.sigma_s, r.tau_s, r.tau_s + 0.7e-9, r.tau_s + 3e-9, 40e-9}) {
      const double integral =
          Simpson([&](double x) { return ReturnDensity(r, x); }, start, t, 20000);
      EXPECT_NEAR(ReturnCdf(r, t), integral, kTolerance)
          << "tau " << r.tau_s << " sigma " << r.sigma_s << " rate " << r.decay_rate << " at "
          << t;
    }
  }
}

TEST(ReturnCdf, StaysFiniteAndMonotoneWhereTheExponentialTermWouldOverflow) {
  // rate*sigma = 100 takes the erfcx branch; exp(rate^2 sigma^2 / 2) alone would overflow.
  const Return r{5e-9, 1.0, 1e-9, 1.0 / 0.01e-9};
  double previous = 0.0;
  for (double t = 0.0; t < 12e-9; t += 0.05e-9) {
    const double value = ReturnCdf(r, t);
    ASSERT_TRUE(std::isfinite(value)) << t;
    EXPECT_GE(value, previous - 1e-15) << t;
    previous = value;
  }
  // Nearly a Gaussian of mean tau + 1/rate: half the light before it.
  EXPECT_NEAR(ReturnCdf(r, r.tau_s + 0.01e-9), 0.5, 1e-3);
}

TEST(ReturnCdf, DiracJumpsAfterItsDelay) {
  const Return r{7e-9, 2.0};
  EXPECT_EQ(ReturnCdf(r, 7e-9), 0.0);  // light in [0, tau): the Dirac itself is not yet in
  EXPECT_EQ(ReturnCdf(r, 7.0001e-9), 1.0);
}

TEST(ReturnMode, IsTheDensityMaximum) {
  for (const Return& r : TestReturns()) {
    const double mode = ReturnMode(r);
    const double step = 1e-3 * (r.sigma_s + (r.decay_rate > 0 ? 1.0 / r.decay_rate : 0.0));
    EXPECT_GE(ReturnDensity(r, mode), ReturnDensity(r, mode - step)) << r.sigma_s;
    EXPECT_GE(ReturnDensity(r, mode), ReturnDensity(r, mode + step)) << r.sigma_s;
  }
}

TEST(ImpulseResponse, DiracMeasurementsAreTheCoresDiracMoments) {
  // ~1e-16 rounding of exp(i*phi) times the total weight.
  constexpr double kTolerance = 1e-13;
  const ImpulseResponse response{{{3e-9, 0.7}, {17e-9, 0.4}, {41e-9, 1.0}}};
  const int m = 8;
  std::vector<double> phases, weights;
  for (const Return& r : response.returns) {
    phases.push_back(kTwoPi * kBaseFrequencyHz * r.tau_s);
    weights.push_back(r.amplitude);
  }
  std::vector<Complex> moments(m + 1);
  DiracMoments(phases, weights, moments);
  for (int j = 0; j <= m; ++j) {
    const Complex measured = response.Measure(j * kBaseFrequencyHz);
    EXPECT_NEAR(measured.real(), moments[j].real(), kTolerance) << j;
    EXPECT_NEAR(measured.imag(), moments[j].imag(), kTolerance) << j;
  }
}

TEST(ImpulseResponse, EmgMeasurementIsTheFourierTransformOfItsDensity) {
  constexpr double kTolerance = 1e-8;  // Simpson with 40000 panels, smooth integrand
  for (const Return& r : TestReturns()) {
    // The exponential's kink at its onset needs its own grid; the Gaussian is tested by the CDF.
    if (r.sigma_s == 0.0 || r.decay_rate == 0.0) continue;
    const ImpulseResponse response{{r}};
    for (double f : {11e6, 23e6, 69e6, 184e6}) {
      const double omega = kTwoPi * f;
      const Complex integral = Simpson(
          [&](double t) { return ReturnDensity(r, t) * std::polar(1.0, omega * t); },
          r.tau_s - 12.0 * r.sigma_s, r.tau_s + 12.0 * r.sigma_s + 40.0 / r.decay_rate, 40000);
      EXPECT_NEAR(std::abs(response.Measure(f) - integral), 0.0, kTolerance)
          << "f " << f << " sigma " << r.sigma_s;
    }
  }
}

TEST(ImpulseResponse, CircleCumulativeHasTheMomentsOfTheMeasurements) {
  // A response whose last tail crosses T: wrapping must keep the moments at multiples of 1/T.
  const ImpulseResponse response{
      {{2e-9, 0.5}, {30e-9, 1.0, 0.6e-9, 1.0 / 5e-9}, {40e-9, 0.3, 0.2e-9, 1.0 / 3e-9}}};
  EXPECT_GT(response.LightOutside(kPeriodS), 0.05);  // the test needs real wrapping
  constexpr int cells = 50000;
  // Evaluated at cell midpoints, the Dirac's phase is off by at most j*pi/cells (times its
  // weight 0.5); the continuous parts are integrated to O(1/cells^2).
  constexpr double kTolerance = 0.5 * 3 * std::numbers::pi / cells + 1e-6;
  for (int j = 0; j <= 3; ++j) {
    // Riemann-Stieltjes sum over the circle cumulative; the Dirac is a jump in one cell.
    Complex sum(0.0, 0.0);
    double previous = 0.0;
    for (int n = 1; n <= cells; ++n) {
      const double tau = kPeriodS * n / cells;
      const double value = response.CumulativeOnCircle(tau, kPeriodS);
      sum += (value - previous) * std::polar(1.0, kTwoPi * j * (tau - 0.5 * kPeriodS / cells) /
                                                      kPeriodS);
      previous = value;
    }
    EXPECT_NEAR(std::abs(sum - response.Measure(j * kBaseFrequencyHz)), 0.0, kTolerance) << j;
  }
  EXPECT_NEAR(response.CumulativeOnCircle(kPeriodS, kPeriodS), response.TotalLight(), 1e-12);
}

TEST(ImpulseResponse, DiracBeyondThePeriodWrapsAround) {
  const ImpulseResponse response{{{kPeriodS + 5e-9, 1.0}}};
  EXPECT_THAT(response.JumpsOnCircle(kPeriodS),
              ::testing::ElementsAre(::testing::DoubleNear(5e-9, 1e-18)));
  EXPECT_EQ(response.CumulativeOnCircle(4.9e-9, kPeriodS), 0.0);
  EXPECT_EQ(response.CumulativeOnCircle(5.1e-9, kPeriodS), 1.0);
  EXPECT_EQ(response.LightOutside(kPeriodS), 1.0);
}

TEST(ImpulseResponse, FirstReturnSkipsReturnsBelowTheThreshold) {
  const Return emg{12e-9, 1.0, 0.5e-9, 1.0 / 2e-9};
  const ImpulseResponse response{{{3e-9, 0.05}, emg, {20e-9, 0.8}}};
  EXPECT_DOUBLE_EQ(response.FirstReturnTau(0.1), ReturnMode(emg));
  EXPECT_DOUBLE_EQ(response.FirstReturnTau(0.01), 3e-9);
}

TEST(SeparatedDelays, KeepsTheRangeAndTheSeparation) {
  RandomStream random({7});
  for (int trial = 0; trial < 200; ++trial) {
    const std::vector<double> delays = SeparatedDelays(8, 1e-9, 42e-9, 2e-9, random);
    ASSERT_EQ(delays.size(), 8u);
    EXPECT_GE(delays.front(), 1e-9);
    EXPECT_LE(delays.back(), 42e-9);
    for (size_t i = 1; i < delays.size(); ++i) EXPECT_GE(delays[i] - delays[i - 1], 2e-9 - 1e-21);
  }
}

TEST(CornerTruth, MomentsMatchTheSimulatorsGroundTruth) {
  // The simulator stores its true moments as float: ~1e-7 relative.
  constexpr double kTolerance = 2e-6;
  constexpr int kWidth = 16, kHeight = 12;
  absl::StatusOr<CornerTruth> truth = MakeCornerTruth(kWidth, kHeight);
  ASSERT_TRUE(truth.ok()) << truth.status();
  ASSERT_FALSE(truth->lit_pixels.empty());

  SimulatorOptions options;
  options.scene = "corner";
  options.width = kWidth;
  options.height = kHeight;
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSimulator(options);
  ASSERT_TRUE(source.ok()) << source.status();
  absl::StatusOr<GroundTruth> expected = (*source)->GroundTruthAt(0.0);
  ASSERT_TRUE(expected.ok()) << expected.status();
  const MomentImage& moments = expected->moments;
  const double f = options.schedule.base_frequency_hz;
  for (int64_t p : truth->lit_pixels) {
    const ImpulseResponse& response = truth->pixels[p];
    ASSERT_EQ(response.returns.size(), 2u);  // the direct Dirac first, then the bounce
    EXPECT_EQ(response.returns[0].sigma_s, 0.0);
    EXPECT_GT(response.returns[1].sigma_s, 0.0);
    const double c0 = response.TotalLight();
    const double expected_c0 = moments.real[p];
    for (int j = 1; j <= moments.order; ++j) {
      const Complex ours = response.Measure(j * f) / c0;
      const int64_t i = int64_t{j} * moments.geometry.pixel_count() + p;
      EXPECT_NEAR(ours.real(), moments.real[i] / expected_c0, kTolerance) << p << " j " << j;
      EXPECT_NEAR(ours.imag(), moments.imag[i] / expected_c0, kTolerance) << p << " j " << j;
    }
  }
}

}  // namespace
}  // namespace transient::eval

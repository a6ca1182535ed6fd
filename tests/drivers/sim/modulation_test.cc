// The effective modulation: its tabulated shape and its Fourier coefficients describe the same
// function, and the split of thesis eq. 8.7 multiplies harmonic h by sum_k w_k exp(-i*h*theta_k).
#include "sim/modulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "transient/reconstruct/acquisition.h"

namespace transient::sim {
namespace {

// A DFT of 8192 samples of the linearly interpolated table: harmonics above 8192 alias in with
// |S_h| ~ 1/h^2 < 2e-8, and linear interpolation between 4096 samples changes the coefficients
// of h <= 9 by (h*pi/4096)^2/6 relative, below 5e-6 * |S_h| <= 1e-6 absolute.
constexpr double kCoefficientTolerance = 1e-6;

// Coefficient h of the Fourier series of the tabulated t, by a DFT.
Complex Dft(const SplitModulation& t, int h) {
  constexpr int kSamples = 8192;
  Complex sum(0.0, 0.0);
  for (int i = 0; i < kSamples; ++i) {
    const double x = kTwoPi * i / kSamples;
    sum += t(x) * std::polar(1.0, -h * x);
  }
  return sum / static_cast<double>(kSamples);
}

struct Case {
  Waveform waveform;
  double duty;
  SamplingScheme sampling;
  int phase_steps;
  const char* name;
};

class SplitModulationTest : public ::testing::TestWithParam<Case> {};

TEST_P(SplitModulationTest, CoefficientsAreTheFourierSeriesOfTheTable) {
  const Case c = GetParam();
  ScheduleOptions options;
  options.sampling = c.sampling;
  options.phase_steps = c.phase_steps;
  const AcquisitionSchedule schedule = *AcquisitionSchedule::Create(options);
  const SplitModulation t(c.waveform, c.duty, schedule.sub_exposures());
  for (int h = 1; h <= 9; ++h) {
    const Complex expected = h <= t.highest_harmonic() ? t.coefficients()[h] : Complex(0.0, 0.0);
    EXPECT_NEAR(std::abs(Dft(t, h) - expected), 0.0, kCoefficientTolerance) << "h = " << h;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Waveforms, SplitModulationTest,
    ::testing::Values(
        Case{Waveform::kSinusoid, 0.5, SamplingScheme::kFourBucket, 1, "SinusoidFourBucket"},
        Case{Waveform::kTriangle, 0.5, SamplingScheme::kFourBucket, 1, "TriangleFourBucket"},
        Case{Waveform::kSquare, 0.25, SamplingScheme::kFourBucket, 1, "SquareDuty25FourBucket"},
        Case{Waveform::kSquare, 0.5, SamplingScheme::kArccos, 8, "SquareArccos8"},
        Case{Waveform::kTriangle, 0.5, SamplingScheme::kHarmonicCancellation, 3,
             "TriangleHarmonicCancellation3"}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

TEST(EffectiveModulation, IsAntisymmetricUnderHalfAPeriodAndBounded) {
  for (Waveform w : {Waveform::kSinusoid, Waveform::kSquare, Waveform::kTriangle}) {
    for (double x = -7.0; x < 7.0; x += 0.01) {
      const double s = EffectiveModulation(w, 0.3, x);
      EXPECT_NEAR(EffectiveModulation(w, 0.3, x - std::numbers::pi), -s, 1e-12);
      EXPECT_LE(std::abs(s), 1.0 + 1e-12);
    }
  }
}

TEST(EffectiveModulation, SinusoidTableIsTheCosine) {
  // Linear interpolation of 4096 samples: error <= (2*pi/4096)^2 / 8 = 2.9e-7.
  constexpr double kInterpolation = 3e-7;
  const SubExposure whole{0.0, 1.0};
  const SplitModulation t(Waveform::kSinusoid, 0.5, {&whole, 1});
  for (double x = -20.0; x < 20.0; x += 0.0137) EXPECT_NEAR(t(x), std::cos(x), kInterpolation);
}

}  // namespace
}  // namespace transient::sim

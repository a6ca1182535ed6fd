// Continuous returns go through the Fourier series of the effective modulation, Dirac returns
// through its table: both must describe the same signal formation (thesis §8.2.1).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/fixed_pattern.h"
#include "sim/forward_model.h"
#include "transient/drivers/simulator.h"

namespace transient::sim {
namespace {

// One pixel with one return.
ReturnPlanes OneReturn(double tau_s, double sigma_s, double decay_rate) {
  ReturnPlanes returns;
  returns.Reset({1, 1}, 1);
  returns.tau_s[0] = static_cast<float>(tau_s);
  returns.amplitude[0] = 1e6f;
  returns.sigma_s[0] = static_cast<float>(sigma_s);
  returns.decay_rate[0] = static_cast<float>(decay_rate);
  return returns;
}

ForwardModel MakeModel(Waveform waveform, SamplingScheme sampling) {
  SimulatorOptions options;
  options.width = options.height = 8;  // the pattern's geometry; pixel 0 is used
  options.waveform = waveform;
  options.duty = 0.3;
  options.schedule.sampling = sampling;
  const AcquisitionSchedule schedule = *AcquisitionSchedule::Create(options.schedule);
  return ForwardModel(options, schedule, MakeFixedPattern(options));
}

TEST(ContinuousReturn, NarrowGaussianMatchesTheDiracOfTheTable) {
  // sigma = 1 ps blurs the phase at 69 MHz by 4e-4 rad; the square's kinks then differ from the
  // table's linear interpolation by about that much of the amplitude.
  constexpr double kTolerance = 2e-3;
  for (Waveform w : {Waveform::kSinusoid, Waveform::kTriangle, Waveform::kSquare}) {
    for (SamplingScheme s : {SamplingScheme::kFourBucket, SamplingScheme::kArccos}) {
      const ForwardModel model = MakeModel(w, s);
      ExposureSignals dirac, narrow;
      for (double tau : {3e-9, 17.3e-9, 41e-9}) {
        model.Evaluate(OneReturn(tau, 0.0, 0.0), &dirac);
        model.Evaluate(OneReturn(tau, 1e-12, 0.0), &narrow);
        for (size_t e = 0; e < dirac.differential.size(); ++e) {
          EXPECT_NEAR(narrow.differential[e][0], dirac.differential[e][0],
                      kTolerance * dirac.light[0])
              << WaveformName(w) << " " << SamplingSchemeName(s) << " exposure " << e;
        }
      }
    }
  }
}

TEST(ContinuousReturn, WideReturnsLoseContrast) {
  // An EMG spread over many nanoseconds smears the phasor: its modulated signals shrink.
  const ForwardModel model = MakeModel(Waveform::kTriangle, SamplingScheme::kArccos);
  ExposureSignals narrow, wide;
  model.Evaluate(OneReturn(10e-9, 0.1e-9, 0.0), &narrow);
  model.Evaluate(OneReturn(10e-9, 3e-9, 1.0 / 5e-9), &wide);
  double narrow_energy = 0.0, wide_energy = 0.0;
  for (size_t e = 2; e < narrow.differential.size(); ++e) {
    narrow_energy += std::pow(narrow.differential[e][0], 2);
    wide_energy += std::pow(wide.differential[e][0], 2);
  }
  EXPECT_LT(wide_energy, 0.5 * narrow_energy);
  EXPECT_EQ(wide.light[0], narrow.light[0]);
}

}  // namespace
}  // namespace transient::sim

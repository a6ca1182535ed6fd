// Capture and demodulation helpers of the simulator tests.
#include "tests/drivers/sim/sim_test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>


namespace transient::sim::testing {

std::unique_ptr<CaptureSource> OpenOrDie(absl::string_view uri) {
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(uri);
  EXPECT_TRUE(source.ok()) << uri << ": " << source.status();
  if (!source.ok()) return nullptr;
  return *std::move(source);
}

std::vector<RawFrame> CaptureCycle(CaptureSource& source) {
  std::vector<RawFrame> frames(source.schedule().raw_frames_per_frame());
  for (RawFrame& frame : frames) {
    const absl::Status status = source.Next(absl::Seconds(10), &frame);
    EXPECT_TRUE(status.ok()) << status;
  }
  return frames;
}

std::vector<std::vector<Complex>> Demodulate(const std::vector<RawFrame>& cycle,
                                             const AcquisitionSchedule& schedule) {
  const int m = schedule.order();
  const int64_t count = cycle.front().geometry.pixel_count();
  std::vector<std::vector<Complex>> moments(m + 1, std::vector<Complex>(count));
  const Complex gain = schedule.nominal_gain();
  // Z of the four buckets of harmonic j (take 0).
  auto phasor = [&](int j, double frequency_hz, int64_t p) {
    double bucket[4] = {0, 0, 0, 0};
    for (const RawFrame& frame : cycle) {
      const ExposureConfig& c = frame.config;
      if (c.take != 0 || c.harmonic != j || c.frequency_hz != frequency_hz) continue;
      const int b = static_cast<int>(std::lround(c.phase_shift_rad / (0.5 * std::numbers::pi)));
      bucket[b % 4] = frame.pixels[p];
    }
    return Complex(0.5 * (bucket[0] - bucket[2]), 0.5 * (bucket[1] - bucket[3]));
  };
  const ScheduleOptions& o = schedule.options();
  for (int64_t p = 0; p < count; ++p) {
    for (int j = 1; j <= m; ++j) moments[j][p] = phasor(j, j * o.base_frequency_hz, p) / gain;
    if (o.zeroth == ZerothScheme::kUnmodulatedPair) {
      double on = 0.0, off = 0.0;
      for (const RawFrame& frame : cycle) {
        if (frame.config.take != 0 || frame.config.harmonic != 0) continue;
        (frame.config.illumination ? on : off) = frame.pixels[p];
      }
      moments[0][p] = on - off;
    } else if (o.zeroth == ZerothScheme::kLowFrequencyProxy) {
      moments[0][p] = std::abs(phasor(0, o.proxy_frequency_hz, p) / gain);
    }
  }
  return moments;
}

std::vector<std::vector<Complex>> CalibrationFactors(
    const std::vector<std::vector<Complex>>& dirac) {
  std::vector<std::vector<Complex>> factors = dirac;
  for (size_t j = 0; j < dirac.size(); ++j) {
    for (size_t p = 0; p < dirac[j].size(); ++p) factors[j][p] = dirac[0][p] / dirac[j][p];
  }
  return factors;
}

void ApplyFactors(const std::vector<std::vector<Complex>>& factors,
                  std::vector<std::vector<Complex>>* moments) {
  for (size_t j = 1; j < factors.size(); ++j) {
    for (size_t p = 0; p < factors[j].size(); ++p) (*moments)[j][p] *= factors[j][p];
  }
}

Complex TrueMoment(const GroundTruth& truth, int j, int64_t p) {
  return {truth.moments.real_plane(j)[p], truth.moments.imag_plane(j)[p]};
}

}  // namespace transient::sim::testing

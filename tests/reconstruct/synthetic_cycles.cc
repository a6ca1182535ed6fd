// Synthetic capture cycles (synthetic_cycles.h).
#include "tests/reconstruct/synthetic_cycles.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tests/support/status_matchers.h"

namespace transient::testing {
namespace {

constexpr double kPi = std::numbers::pi;

}  // namespace

AcquisitionSchedule MakeSchedule(SamplingScheme sampling, int phase_steps, ZerothScheme zeroth,
                                 int takes, int order) {
  ScheduleOptions options;
  options.order = order;
  options.sampling = sampling;
  options.phase_steps = phase_steps;
  options.zeroth = zeroth;
  options.takes = takes;
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
  EXPECT_THAT(schedule.status(), IsOk());
  return *std::move(schedule);
}

Scene RandomScene(ImageGeometry geometry, int order, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Scene s;
  s.geometry = geometry;
  s.order = order;
  const int64_t n = geometry.pixel_count();
  s.c.assign(static_cast<size_t>(order + 1), std::vector<Complex>(static_cast<size_t>(n)));
  for (int64_t p = 0; p < n; ++p) {
    s.c0.push_back(5.0 + 5.0 * u(rng));
    s.offset.push_back(20.0 + 30.0 * u(rng));
    for (int j = 1; j <= order; ++j) {
      s.c[j][p] = std::polar(0.9 * u(rng) * s.c0.back(), 2.0 * kPi * u(rng));
    }
  }
  return s;
}

// One raw frame of `config` by the measurement convention (demodulation.h), evaluated through
// the sub-exposures rather than through nominal_gain(): M(beta) = offset +
// sum_k w_k Re(exp(-i (beta + theta_k)) c_j); unmodulated pair: offset + c_0 and offset.
RawFrame Synthesize(const AcquisitionSchedule& schedule, const Scene& scene,
                    const ExposureConfig& config, int64_t cycle, uint64_t sequence, double sigma,
                    std::mt19937_64& rng, double scale, double phase_slip) {
  std::normal_distribution<double> noise(0.0, 1.0);
  RawFrame frame;
  frame.config = config;
  frame.config.cycle = cycle;
  frame.config.sequence = sequence;
  frame.geometry = scene.geometry;
  const int64_t n = scene.geometry.pixel_count();
  frame.pixels.resize(static_cast<size_t>(n));
  // The exposure is linear in c: sum the sub-exposures' phasors once per frame.
  Complex response{0.0, 0.0};
  for (const SubExposure& s : schedule.sub_exposures()) {
    response +=
        s.weight * std::polar(1.0, -(config.phase_shift_rad + phase_slip + s.phase_shift_rad));
  }
  for (int64_t p = 0; p < n; ++p) {
    double value = scene.offset[p];
    if (config.frequency_hz == 0.0) {
      if (config.illumination) value += scene.c0[p];
    } else {
      const Complex c =
          config.harmonic == 0 ? std::polar(scene.c0[p], kProxyPhase) : scene.c[config.harmonic][p];
      value += (response * c).real();
    }
    frame.pixels[p] = static_cast<float>(scale * value + sigma * noise(rng));
  }
  return frame;
}

std::vector<RawFrame> SynthesizeCycle(const AcquisitionSchedule& schedule, const Scene& scene,
                                      int64_t cycle, double sigma, std::mt19937_64& rng) {
  std::vector<RawFrame> frames;
  const int n = schedule.raw_frames_per_frame();
  for (int i = 0; i < n; ++i) {
    frames.push_back(Synthesize(schedule, scene, schedule.exposures()[i], cycle,
                                static_cast<uint64_t>(cycle * n + i), sigma, rng));
  }
  return frames;
}

}  // namespace transient::testing

// The emulated sensor's light from the simulator (simulated_phases.h).
#include "tests/drivers/v4l2/simulated_phases.h"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace transient::v4l2::testing {

SimulatedPhases::SimulatedPhases(std::string scene_and_keys, bool signed_output)
    : scene_and_keys_(std::move(scene_and_keys)), signed_output_(signed_output) {}

std::string SimulatedPhases::CameraUri(double frequency_hz, double exposure_s,
                                       ImageGeometry geometry) const {
  const char separator = scene_and_keys_.find('?') == std::string::npos ? '?' : '&';
  return absl::StrFormat(
      "sim:%s%cf=%.17g&m=1&scheme=four-bucket&zeroth=estimated&exposure=%.17g&width=%d&"
      "height=%d&pace=fast&seed=%d",
      scene_and_keys_, separator, frequency_hz, exposure_s, geometry.width, geometry.height,
      // Each frequency its own noise: cameras with one seed would repeat the same noise at
      // every harmonic, which no sensor does.
      static_cast<int>(std::llround(frequency_hz / 1e3)) + 1);
}

std::vector<std::vector<int32_t>> SimulatedPhases::Render(const ProgrammedSequence& sequence,
                                                          ImageGeometry geometry) {
  const long long integration_us =
      sequence.integration_us.empty() ? 0 : static_cast<long long>(sequence.integration_us[0]);
  const auto key = std::make_pair(std::llround(sequence.frequency_hz), integration_us);
  auto it = cameras_.find(key);
  if (it == cameras_.end()) {
    absl::StatusOr<std::unique_ptr<CaptureSource>> camera = OpenSource(
        CameraUri(sequence.frequency_hz, static_cast<double>(integration_us) * 1e-6, geometry));
    if (!camera.ok() || !(*camera)->Start().ok()) {
      throw std::runtime_error(absl::StrCat("emulated sensor: ", camera.status().ToString()));
    }
    it = cameras_.emplace(key, *std::move(camera)).first;
  }
  // One take of the m = 1 four-bucket schedule: buckets 0, pi/2, pi, 3 pi/2 at nu.
  std::vector<RawFrame> buckets(4);
  for (RawFrame& bucket : buckets) {
    if (absl::Status s = it->second->Next(absl::Seconds(10), &bucket); !s.ok()) {
      throw std::runtime_error(absl::StrCat("emulated sensor: ", s.ToString()));
    }
  }
  const double black_level = signed_output_ ? 2048.0 : 0.0;  // 12-bit ADC: mid-scale (sensor.h)
  std::vector<std::vector<int32_t>> frames;
  for (int64_t phase_deg : sequence.phases_deg) {
    const double phase = static_cast<double>(phase_deg) * std::numbers::pi / 180.0;
    const RawFrame* match = nullptr;
    for (const RawFrame& bucket : buckets) {
      if (std::abs(bucket.config.phase_shift_rad - phase) < 1e-9) match = &bucket;
    }
    if (match == nullptr) {
      throw std::runtime_error(absl::StrCat("emulated sensor: no bucket at ", phase_deg, " deg"));
    }
    std::vector<int32_t> samples(match->pixels.size());
    for (size_t p = 0; p < samples.size(); ++p) {
      samples[p] = static_cast<int32_t>(std::lround(match->pixels[p] - black_level));
    }
    frames.push_back(std::move(samples));
  }
  return frames;
}

Renderer SimulatedPhases::AsRenderer() {
  // No exception may leave the handler (umockdev calls it from C): a failure renders nothing,
  // which the code under test sees as a stall.
  return [this](const ProgrammedSequence& sequence, ImageGeometry geometry) {
    try {
      return Render(sequence, geometry);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return std::vector<std::vector<int32_t>>{};
    }
  };
}

}  // namespace transient::v4l2::testing

// The emulated sensor's light from the simulator (simulated_phases.h).
#include "tests/drivers/v4l2/simulated_phases.h"

#include <algorithm>
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
                                       ImageGeometry geometry, double delay_ns) const {
  const char separator = scene_and_keys_.find('?') == std::string::npos ? '?' : '&';
  return absl::StrFormat(
      "sim:%s%cf=%.17g&m=1&scheme=four-bucket&zeroth=estimated&exposure=%.17g&width=%d&"
      "height=%d&pace=fast&delay_ns=%.17g&seed=%d",
      scene_and_keys_, separator, frequency_hz, exposure_s, geometry.width, geometry.height,
      delay_ns,
      // Each frequency its own noise: cameras with one seed would repeat the same noise at
      // every harmonic, which no sensor does.
      static_cast<int>(std::llround(frequency_hz / 1e3)) + 1);
}

std::vector<std::vector<int32_t>> SimulatedPhases::Render(const ProgrammedSequence& sequence,
                                                          ImageGeometry geometry) {
  // One capture cycle (the four buckets) of each camera the sequence needs.
  std::map<std::tuple<long long, long long, long long>, std::vector<RawFrame>> cycles;
  std::vector<std::vector<int32_t>> frames;
  const double black_level = signed_output_ ? 2048.0 : 0.0;  // 12-bit ADC: mid-scale (sensor.h)
  for (size_t k = 0; k < sequence.phases_deg.size(); ++k) {
    const int64_t phase_deg = sequence.phases_deg[k] % 360;
    const int64_t bucket_deg = phase_deg / 90 * 90;
    const int64_t rest_deg = phase_deg - bucket_deg;
    const long long integration_us =
        sequence.integration_us.empty()
            ? 0
            : static_cast<long long>(sequence.integration_us[std::min(
                  k, sequence.integration_us.size() - 1)]);
    const auto key = std::make_tuple(std::llround(sequence.frequency_hz), integration_us,
                                     static_cast<long long>(rest_deg));
    auto camera = cameras_.find(key);
    if (camera == cameras_.end()) {
      const double delay_ns = -static_cast<double>(rest_deg) / (360.0 * sequence.frequency_hz) * 1e9;
      absl::StatusOr<std::unique_ptr<CaptureSource>> opened = OpenSource(CameraUri(
          sequence.frequency_hz, static_cast<double>(integration_us) * 1e-6, geometry, delay_ns));
      if (!opened.ok() || !(*opened)->Start().ok()) {
        throw std::runtime_error(absl::StrCat("emulated sensor: ", opened.status().ToString()));
      }
      camera = cameras_.emplace(key, *std::move(opened)).first;
    }
    auto cycle = cycles.find(key);
    if (cycle == cycles.end()) {
      std::vector<RawFrame> buckets(4);  // one take of the m = 1 four-bucket schedule
      for (RawFrame& bucket : buckets) {
        if (absl::Status s = camera->second->Next(absl::Seconds(10), &bucket); !s.ok()) {
          throw std::runtime_error(absl::StrCat("emulated sensor: ", s.ToString()));
        }
      }
      cycle = cycles.emplace(key, std::move(buckets)).first;
    }
    const double bucket = static_cast<double>(bucket_deg) * std::numbers::pi / 180.0;
    const RawFrame* match = nullptr;
    for (const RawFrame& frame : cycle->second) {
      if (std::abs(frame.config.phase_shift_rad - bucket) < 1e-9) match = &frame;
    }
    if (match == nullptr) {
      throw std::runtime_error(absl::StrCat("emulated sensor: no bucket at ", bucket_deg, " deg"));
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

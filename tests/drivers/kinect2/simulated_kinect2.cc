// The simulated Kinect v2 as the emulated camera's picture (simulated_kinect2.h).
#include "tests/drivers/kinect2/simulated_kinect2.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <span>

#include "kinect2/kinect2_format.h"
#include "sim/fixed_pattern.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/simulator.h"

namespace transient::kinect2::testing {

SimulatedKinect2::SimulatedKinect2(const std::string& scene_uri) {
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(scene_uri);
  if (!options.ok()) return;
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(scene_uri);
  if (!source.ok() || !(*source)->Start().ok()) return;
  const int steps = options->schedule.buckets;  // 3
  schedule_ = (*source)->schedule();
  for (int n = 0; n < 9; ++n) {
    RawFrame frame;
    if (!(*source)->Next(absl::Seconds(30), &frame).ok()) return;
    // A scene of another size (width= or height= after camera=kinect2) is not this camera's.
    if (frame.pixels.size() != static_cast<size_t>(kWidth) * kHeight) return;
    frames_.push_back(frame);
    // The sub-frame of this exposure: group of its harmonic, step k with bucket (3 - k) % 3.
    int group = 0;
    while (group < 3 && kGroupHarmonics[group] != frame.config.harmonic) ++group;
    const int bucket = static_cast<int>(std::lround(frame.config.phase_shift_rad * steps /
                                                    (2.0 * 3.14159265358979323846))) % steps;
    const int k = (steps - bucket) % steps;
    subframes_[static_cast<size_t>(3 * group + k)] = std::move(frame.pixels);
  }
  delay_s_ = sim::MakeFixedPattern(*options).delay_s;
  ok_ = true;
}

Renderer SimulatedKinect2::AsRenderer() const {
  return [subframes = subframes_](uint32_t, int subframe, std::span<float> samples) {
    if (subframe >= 9) {
      std::fill(samples.begin(), samples.end(), 0.0f);
    } else {
      std::copy(subframes[static_cast<size_t>(subframe)].begin(),
                subframes[static_cast<size_t>(subframe)].end(), samples.begin());
    }
  };
}

std::array<std::vector<uint16_t>, 3> SimulatedKinect2::P0Tables() const {
  // The decoder turns P0 value v into the factor exp(+i * v * 0.000031 * pi); the delay d needs
  // exp(-i * 2*pi * j * f * d): v = (-j * f * d mod 1) * 2 / 0.000031.
  std::array<std::vector<uint16_t>, 3> tables;
  for (int g = 0; g < 3; ++g) {
    const double j = kGroupHarmonics[g];
    tables[static_cast<size_t>(g)].resize(delay_s_.size());
    for (size_t p = 0; p < delay_s_.size(); ++p) {
      double cycles = -j * 8e6 * delay_s_[p];
      cycles -= std::floor(cycles);
      tables[static_cast<size_t>(g)][p] =
          static_cast<uint16_t>(std::lround(cycles * 2.0 / 0.000031) % 64516);
    }
  }
  return tables;
}

}  // namespace transient::kinect2::testing

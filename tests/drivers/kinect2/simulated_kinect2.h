// The simulated Kinect v2 (sim: camera=kinect2) as the emulated camera's picture: the
// simulator renders one capture cycle of a scene, and its nine raw frames become the
// sub-frames the emulated device encodes and sends (sub-frame s: harmonic 10, 2, 15 for
// s / 3 = 0, 1, 2 and phase step k = s % 3 at -2*pi*k/3, research/libusb.md §1.5). The
// simulated camera's modulation delays are its "factory calibration": P0 tables that undo them.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tests/drivers/kinect2/emulated_kinect2.h"
#include "transient/reconstruct/acquisition.h"

namespace transient::kinect2::testing {

class SimulatedKinect2 {
 public:
  // `scene_uri`: a sim: URI with camera=kinect2 (and pace=fast); the first cycle is rendered.
  // Not ok() when the scene cannot be rendered or its frames are not kWidth x kHeight.
  explicit SimulatedKinect2(const std::string& scene_uri);

  bool ok() const { return ok_; }
  // Sub-frame `subframe` of any frame (the scene holds still): 512 x 424 samples; sub-frame 9
  // (undocumented) is dark.
  Renderer AsRenderer() const;
  // P0 tables whose phase undoes each pixel's modulation delay at each group's frequency.
  std::array<std::vector<uint16_t>, 3> P0Tables() const;
  // The simulator's raw frames of the cycle, as sim: delivers them, with its schedule.
  const std::vector<RawFrame>& frames() const { return frames_; }
  const AcquisitionSchedule& schedule() const { return *schedule_; }

 private:
  bool ok_ = false;
  std::vector<RawFrame> frames_;
  std::optional<AcquisitionSchedule> schedule_;
  std::array<std::vector<float>, 9> subframes_;
  std::vector<double> delay_s_;
};

}  // namespace transient::kinect2::testing

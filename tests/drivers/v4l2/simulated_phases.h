// The emulated sensor's light: each programmed sequence rendered by the project's simulator
// (its forward model, fixed pattern, noise and ADC; drivers/include/transient/drivers/simulator.h).
// A frame at modulation frequency nu, phase phi and integration time t comes from a sim: camera
// of the same scene whose base frequency is nu and m = 1 (four-bucket, zeroth estimated,
// exposure t): the scene's correlation at nu, which is what a sensor modulated at nu measures.
// Its bucket beta (0, 90, 180 or 270 deg) is the one at or below phi; the rest r = phi - beta
// is a shift of the modulation by a delay of -r / (360 nu) (the simulator's M = integral
// s(2 pi nu (tau + d) - beta), so a delay d = -r / (360 nu) measures the bucket at beta + r).
// The simulator's output is black level + (A - B) in ADC counts (sensor.h); a sensor that
// outputs A - B itself (the mlx7502x's default) gives the counts less the black level, signed.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "tests/drivers/v4l2/emulated_tof_sensor.h"
#include "transient/drivers/capture_source.h"

namespace transient::v4l2::testing {

class SimulatedPhases {
 public:
  // `scene_and_keys`: "mirrors?noise=none&..." without f, m, scheme, zeroth, exposure, width,
  // height, pace, seed, delay_ns (set here: the seed from the frequency, the delay 0 but for
  // the phase). `signed_output`: A - B without the black level.
  SimulatedPhases(std::string scene_and_keys, bool signed_output);

  std::vector<std::vector<int32_t>> Render(const ProgrammedSequence& sequence,
                                           ImageGeometry geometry);
  // A Renderer for EmulatedNode that calls Render on this object (which must outlive it).
  Renderer AsRenderer();

  // The sim: URI of the camera that renders `frequency_hz` (for messages and comparisons).
  std::string CameraUri(double frequency_hz, double exposure_s, ImageGeometry geometry,
                        double delay_ns = 0.0) const;

 private:
  std::string scene_and_keys_;
  bool signed_output_;
  // By frequency (Hz), integration time (us) and phase beyond the bucket (deg).
  std::map<std::tuple<long long, long long, long long>, std::unique_ptr<CaptureSource>> cameras_;
};

}  // namespace transient::v4l2::testing

// `transient moments`: a capture file demodulated, calibrated and smoothed into a moment file
// through the frame pipeline.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"

namespace transient::tools {

// `transient moments CAPTURE --calibration FILE --out FILE`.
struct MomentsArgs {
  std::string capture_path = {};
  std::string output_path = {};
  std::string calibration_path = {};  // "" = the calibration embedded in the capture, if any
  bool uncalibrated = false;     // allow demodulating without any calibration
  double smoothing_sigma_px = 0.6;  // thesis §8.5; 0 = none
  bool video = false;  // fill outlier captures from the previous frame (thesis §8.5)

  absl::Status Validate() const;
};

struct MomentsSummary {
  std::string output_path = {};
  int64_t frames_written = 0;     // transient frames
  int64_t cycles_dropped = 0;     // incomplete or refused cycles, not reconstructed
  int64_t raw_frames_dropped = 0; // foreign, duplicated or missing-cycle raw frames
  int64_t raw_frames_rejected = 0;  // outliers left out of averages or filled
  int64_t filled_pixels = 0;
  int64_t saturated_pixels = 0;
  std::string calibration = {};  // what was applied
  std::vector<std::string> problems = {};  // one line per dropped cycle (the first few)
};

// Demodulates every complete cycle of a capture, applies the calibration (checked against the
// capture: size, f, m, schemes), smooths, and writes a `transient-moments 1` file with per-frame
// timestamps. A cycle with a missing, duplicated or foreign frame is refused and counted, not
// reconstructed; a capture without a single complete cycle is an error.
[[nodiscard]] absl::StatusOr<MomentsSummary> RunMoments(const MomentsArgs& args,
                                                        const CommandHooks& hooks = {});
std::string FormatMomentsSummary(const MomentsSummary& summary);

}  // namespace transient::tools

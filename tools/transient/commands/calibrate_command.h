// `transient calibrate`: a calibration measured against a Dirac at zero (thesis §8.3.2).
#pragma once

#include <cstdint>
#include <string>
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"

namespace transient::tools {

// `transient calibrate --source URI --out FILE --takes N`.
struct CalibrateArgs {
  std::string source_uri = "sim:calibration";
  std::string output_path = {};
  int takes = 20;  // capture cycles averaged (with outlier rejection), 1..256

  absl::Status Validate() const;
};

struct CalibrateSummary {
  std::string output_path = {};
  int takes_averaged = 0;  // raw takes per exposure that went into the factors
  int frames_rejected = 0; // outlier raw frames left out
  int64_t usable_pixels = 0, pixels = 0;
  std::string schedule = {};
};

// Averages `takes` cycles of the source (a Dirac at zero: the `calibration` scene, or a real
// camera looking into its diffused light source, thesis fig. 8.3), rejecting outlier frames,
// and writes the per-pixel factors (`transient-calibration 1`).
[[nodiscard]] absl::StatusOr<CalibrateSummary> RunCalibrate(const CalibrateArgs& args,
                                                            const CommandHooks& hooks = {});
std::string FormatCalibrateSummary(const CalibrateSummary& summary);

}  // namespace transient::tools

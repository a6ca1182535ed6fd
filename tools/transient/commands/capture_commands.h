// The measurement subcommands of `transient`: record a source (or the simulator) into a capture
// file, calibrate against a Dirac at zero, turn a capture into a moment file, and describe any
// of the project's files. They run in-process; main.cc only maps the command line to them.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/command_hooks.h"

namespace transient::tools {

// `transient record --source URI --out FILE (--frames N | --seconds S)` and, through
// SimulatorUri() (simulator.h), `transient sim SCENE --out FILE ...`.
struct RecordArgs {
  std::string source_uri = {};
  std::string output_path = {};
  int64_t frames = 0;     // transient frames (capture cycles) to record; 0 = --seconds decides
  double seconds = 0.0;   // wall-clock seconds to record; 0 = --frames decides
  int deflate_level = 1;  // 0..9
  bool ground_truth = true;  // store the source's ground truth when it has one

  // Exactly one of frames > 0 and seconds > 0; deflate 0..9; both paths given.
  absl::Status Validate() const;
};

struct RecordSummary {
  std::string output_path = {};
  std::string source_uri = {};
  int64_t raw_frames = 0;
  int64_t cycles = 0;  // complete capture cycles recorded
  double seconds = 0.0;
  bool interrupted = false;
  bool ground_truth = false;
  std::string schedule = {};  // AcquisitionSchedule::Describe()
};

// Records raw frames from the source into a new capture file (`transient-capture 1`). The file
// is written in place (never to a temporary name): it is readable up to its last flush even if
// the process is killed. It refuses to overwrite an existing file (AlreadyExists). A source
// that ends (OutOfRange, the end of a replay) ends the recording early without an error.
[[nodiscard]] absl::StatusOr<RecordSummary> RunRecord(const RecordArgs& args,
                                                      const CommandHooks& hooks = {});
std::string FormatRecordSummary(const RecordSummary& summary);

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

// `transient info FILE`: what the file is (by its format attribute), its layout and a summary
// of its content, as lines of text. InvalidArgument for a file of no known format.
[[nodiscard]] absl::StatusOr<std::string> DescribeFile(const std::string& path);

}  // namespace transient::tools

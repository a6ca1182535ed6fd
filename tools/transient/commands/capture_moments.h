// The moments of a capture file through the frame pipeline (frame_pipeline.h): `transient
// moments` writes them into a moment file, `transient view` of a capture draws them without one.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"
#include "transient/formats/capture_file.h"
#include "transient/reconstruct/frame_pipeline.h"

namespace transient::tools {

struct CaptureMeasureOptions {
  std::string calibration_path = {};  // "" = the calibration embedded in the capture, if any
  bool uncalibrated = false;          // allow demodulating without any calibration
  double smoothing_sigma_px = 0.6;    // thesis §8.5; 0 = none
  bool video = false;                 // fill outlier captures from the previous frame
};

// The frame pipeline that measures `capture`, with the calibration `options` name (a file, the
// embedded one, or none when uncalibrated). `calibration` receives what is applied: the file,
// "<capture>: /calibration" or "none". InvalidArgument "<capture>: no calibration: ..." when
// there is none and uncalibrated is false; FailedPrecondition "<calibration> does not fit
// <capture>: ..." naming both values; the calibration file's errors.
[[nodiscard]] absl::StatusOr<FramePipeline> CapturePipeline(const CaptureReader& capture,
                                                            const CaptureMeasureOptions& options,
                                                            std::string* calibration);

// What MeasureCapture dropped and rejected.
struct CaptureMeasureCounts {
  int64_t frames = 0;               // transient frames measured
  int64_t cycles_dropped = 0;       // incomplete or refused cycles
  int64_t raw_frames_dropped = 0;   // foreign, duplicated or unreadable raw frames
  int64_t raw_frames_rejected = 0;  // outliers left out of averages or filled
  int64_t filled_pixels = 0;
  int64_t saturated_pixels = 0;
  std::vector<std::string> problems = {};  // one line per dropped cycle (the first few)
};

// Measures every complete capture cycle of `capture`, in order, and gives each frame of moments
// with the start of its cycle (s) to `sink`. A cycle with a missing, duplicated or foreign frame
// is refused and counted, not measured; the next one goes on. InvalidArgument when not one cycle
// is complete; Cancelled on hooks.cancel; the sink's errors. Progress: raw frames read.
absl::Status MeasureCapture(const CaptureReader& capture, FramePipeline& pipeline,
                            const CommandHooks& hooks, CaptureMeasureCounts* counts,
                            const std::function<absl::Status(const MomentImage&, double)>& sink);

}  // namespace transient::tools

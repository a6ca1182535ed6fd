// Measuring a calibration from a live or recorded source looking at a Dirac at zero (thesis
// §8.3.2, fig. 8.3): `transient calibrate` and the daemon's Calibrate RPC share it.
#pragma once

#include <atomic>
#include <functional>

#include "absl/status/statusor.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/calibration.h"

namespace transient {

struct CalibrationCapture {
  CalibrationTable table;
  int frames_rejected = 0;  // outlier raw frames left out of the averages
  int64_t usable_pixels = 0;
};

struct CalibrationCaptureHooks {
  std::function<void(int done, int total)> on_take = nullptr;  // after each complete cycle
  const std::atomic<bool>* cancel = nullptr;                   // Cancelled at the next frame
};

// Starts `source`, averages `takes` complete capture cycles of it (each cycle's own takes
// included) with the demodulator's outlier rejection, stops it, and estimates the per-pixel
// factors. Incomplete cycles are skipped. InvalidArgument when takes is outside 1..256 or the
// source ends (OutOfRange) before enough cycles; FailedPrecondition for a depth camera
// (SamplingScheme::kDepth), which has no moments to calibrate; the source's own errors otherwise.
absl::StatusOr<CalibrationCapture> CaptureCalibration(CaptureSource& source, int takes,
                                                      const CalibrationCaptureHooks& hooks = {});

}  // namespace transient

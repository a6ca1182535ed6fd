// Calibration files, format `transient-calibration 1`: the per-pixel complex correction
// factors of a Dirac-at-zero calibration (calibration.h, thesis §8.3.2) with the schedule they
// were measured with, so that a later capture can check it fits.
//
// Layout (HDF5; [..] are dataset shapes, H x W the sensor image):
//   /                        attribute format = "transient-calibration 1" (string)
//                            attribute base_frequency_hz (float64, Hz): f of the schedule
//                            attribute order (int64): m, 1..16
//                            attribute takes_averaged (int64): takes that went into the factors
//                            attribute takes (int64): takes per frame of the schedule
//                            attribute sampling (string): "four-bucket", "arccos",
//                                      "harmonic-cancellation"
//                            attribute phase_steps (int64): n_phi
//                            attribute zeroth (string): "pair", "proxy", "estimated"
//                            attribute proxy_frequency_hz (float64, Hz)
//                            attribute exposure_s (float64, s): of each raw frame
//   /factors/real            float32 [m+1, H, W]: Re k_j, j = 0..m; NaN where invalid
//   /factors/imag            float32 [m+1, H, W]: Im k_j
//   /factors/valid           uint8 [H, W]: 1 = usable pixel, 0 = not
// A capture file embeds the same attributes and /factors under its group /calibration.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/formats/atomic_output.h"
#include "transient/reconstruct/calibration.h"

namespace transient {

inline constexpr char kCalibrationFormatName[] = "transient-calibration";
inline constexpr int kCalibrationFormatMajor = 1;

// Writes `table` to `path` atomically (AtomicOutput): under a temporary name beside it, put in
// place only when complete, so that a failure or a crash leaves either the old file or the new
// one, never half of one, and no temporary file. kReplace replaces an existing file;
// kNeverReplace refuses one, found at the start or made meanwhile (AlreadyExists), and leaves
// it untouched. InvalidArgument for an inconsistent table (sizes, order, schedule) or a path
// that is a directory, NotFound / PermissionDenied when the directory is missing or cannot be
// written, Internal when HDF5 fails.
absl::Status WriteCalibrationFile(const std::string& path, const CalibrationTable& table,
                                  CommitMode mode = CommitMode::kReplace);

// Reads and validates a calibration file. NotFound, PermissionDenied, InvalidArgument (not
// HDF5, another format, a wrong layout: the message names the object and the rule), DataLoss
// (HDF5 cannot read what the layout promises).
[[nodiscard]] absl::StatusOr<CalibrationTable> ReadCalibrationFile(const std::string& path);

}  // namespace transient

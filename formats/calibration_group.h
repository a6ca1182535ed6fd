// The calibration layout as a group, for the two places it is stored: the root of a calibration
// file and /calibration of a capture (calibration_file.h documents it). Defined with the
// calibration file in calibration_file.cc.
#pragma once

#include <hdf5.h>

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/reconstruct/calibration.h"

namespace transient {

// Sizes, order and schedule of a table about to be written; InvalidArgument naming the rule
// ("calibration order = 0. Violated constraint: 1 <= order <= 16").
absl::Status CheckCalibrationTable(const CalibrationTable& table);

// Writes the format tag, the schedule and takes_averaged attributes and /factors into `group`.
// Internal when HDF5 fails; the table is checked first (CheckCalibrationTable).
absl::Status WriteCalibrationGroup(hid_t group, const CalibrationTable& table);

// Reads and checks the group at `group_path` ("/" for a calibration file, "/calibration" for a
// capture) of `file`. Messages start with "<file_path>: <object>".
absl::StatusOr<CalibrationTable> ReadCalibrationGroup(hid_t file, absl::string_view file_path,
                                                      const std::string& group_path);

}  // namespace transient

// The simulator's ground truth as the optional /ground_truth group of a capture (layout in
// capture_file.h): first_range_m [H, W], return_range_m, return_amplitude, return_spread_m
// [R, H, W] and moments/real, moments/imag [m+1, H, W], all float32.
#pragma once

#include <hdf5.h>

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/ground_truth.h"
#include "transient/reconstruct/image.h"

namespace transient {

// Geometry (the camera's) and sizes of a truth about to be written; InvalidArgument naming the
// rule ("ground truth geometry = 3x3, ... Violated constraint: both are the camera's 7x5").
absl::Status CheckGroundTruth(const GroundTruth& truth, ImageGeometry camera);

// Writes the datasets into `group` (an empty group). Internal when HDF5 fails.
absl::Status WriteGroundTruthGroup(hid_t group, const GroundTruth& truth);

// Reads and checks /ground_truth of `file` (`path` names it in messages) against the camera's
// geometry; R and m come from the file.
absl::StatusOr<GroundTruth> ReadGroundTruthGroup(hid_t file, const std::string& path,
                                                 ImageGeometry camera);

}  // namespace transient

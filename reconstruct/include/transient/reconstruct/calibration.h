// Calibration against a Dirac at zero (thesis §8.3.2): per pixel and harmonic, the complex factor
// that turns the measured moments of light arriving at time of flight zero into c_0 for every j.
// Multiplying it onto later measurements removes per-pixel phase offsets and gains.
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/image.h"

namespace transient {

// Complex factors k_j per pixel, j = 0..m, as float32 planes like MomentImage.
// k_j = reference / (measured c_j) for j >= 1, where the reference is the measured c_0 (zeroth
// moment measured) or |measured c_1| (estimated; then only relative gains are corrected and
// k_1 has unit modulus); on a schedule with a harmonic set (ScheduleOptions::harmonics) the
// modulus of its lowest harmonic, and k_j = 1 for the harmonics it does not measure. A camera's
// factory phase tables (the Kinect v2's P0) are such a table with unit moduli. k_0 = 1: c_0 defines the unit. An unusable calibration pixel (no
// light, saturated, invalid) has valid[p] = 0 and NaN factors; moments it is applied to become
// invalid.
struct CalibrationTable {
  ImageGeometry geometry;
  int order = 0;                 // m
  double base_frequency_hz = 0;  // f of the schedule it was measured with
  ScheduleOptions schedule;      // the schedule it was measured with (takes may differ)
  std::vector<float> real, imag; // (m+1) planes
  std::vector<uint8_t> valid;    // pixel_count(); 1 = usable
  int takes_averaged = 0;        // how many takes went into it

  // Sizes, order, frequency; the message names the violated constraint.
  absl::Status Validate() const;
};

// Refuses a calibration that does not fit moments measured with `schedule` on `geometry`:
// FailedPrecondition naming both values, e.g. "calibration is for 163x120 pixels, the capture
// has 320x240", "calibration f = 23 MHz, capture f = 20 MHz", "calibration m = 3, capture m = 4",
// or a different sampling, number of phase steps, harmonic set or zeroth-moment scheme. A depth
// camera's schedule (SamplingScheme::kDepth) fits no calibration: "the source delivers depth,
// not modulated captures: ...".
absl::Status CheckCalibrationMatches(const CalibrationTable& calibration,
                                     const ScheduleOptions& schedule, ImageGeometry geometry);

// Estimates the factors from moments of a Dirac at zero (the `calibration` scene, fig. 8.3),
// averaged over `takes_averaged` takes. Pixels with c_0 (or |c_1|) not above `min_signal`
// (sensor units) or invalid input are marked unusable.
absl::StatusOr<CalibrationTable> EstimateCalibration(const MomentImage& dirac_at_zero,
                                                     const ScheduleOptions& schedule,
                                                     int takes_averaged, double min_signal = 0.0);

// c_j <- k_j * c_j for every pixel and j >= 1; pixels unusable in the calibration become invalid.
// FailedPrecondition when geometry or order differ (both values in the message).
absl::Status ApplyCalibration(const CalibrationTable& calibration, MomentImage* moments);

}  // namespace transient

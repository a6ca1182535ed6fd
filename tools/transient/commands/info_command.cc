// transient info: a file identified by its format tag and described.
#include "tools/transient/commands/info_command.h"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/formats/calibration_file.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/file_format.h"
#include "transient/formats/h5.h"
#include "transient/formats/moment_file.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/percentile.h"

namespace transient::tools {
namespace {

std::string Frequency(double hz) {
  if (hz >= 1e6) return absl::StrFormat("%g MHz", hz / 1e6);
  if (hz >= 1e3) return absl::StrFormat("%g kHz", hz / 1e3);
  return absl::StrFormat("%g Hz", hz);
}

}  // namespace

namespace {

std::string DescribeCamera(const CameraInfo& camera) {
  return absl::StrFormat(
      "camera: %dx%d px, fx %.2f fy %.2f cx %.2f cy %.2f px, %s, frame period %.3f ms",
      camera.geometry.width, camera.geometry.height, camera.intrinsics.fx, camera.intrinsics.fy,
      camera.intrinsics.cx, camera.intrinsics.cy,
      camera.model.empty() ? "unnamed" : camera.model, camera.frame_period_s * 1e3);
}

absl::StatusOr<std::string> DescribeCapture(const std::string& path) {
  absl::StatusOr<CaptureReader> capture = CaptureReader::Open(path);
  if (!capture.ok()) return capture.status();
  const AcquisitionSchedule& schedule = capture->schedule();
  const int64_t frames = capture->frames();
  std::string text = absl::StrCat(path, ": capture (transient-capture 1)\n  source: ",
                                  capture->source_uri(), "\n  ", DescribeCamera(capture->camera()),
                                  "\n  schedule: ", schedule.Describe());
  const int64_t per_cycle = schedule.raw_frames_per_frame();
  absl::StrAppend(&text, absl::StrFormat(
                             "\n  frames: %d raw (%s, saturation at %g) = %d complete transient "
                             "frames%s",
                             frames,
                             capture->pixel_type() == CapturePixelType::kUint16 ? "uint16"
                                                                                 : "float32",
                             capture->saturation_level(), frames / per_cycle,
                             frames % per_cycle == 0
                                 ? ""
                                 : absl::StrCat(" + ", frames % per_cycle, " raw frames")));
  if (frames > 0) {
    const double first = capture->config(0).timestamp_s;
    const double last = capture->config(frames - 1).timestamp_s;
    absl::StrAppend(&text, absl::StrFormat("\n  time: %.3f s to %.3f s (%.3f s)", first, last,
                                           last - first));
  }
  if (capture->ground_truth().has_value()) {
    const GroundTruth& truth = *capture->ground_truth();
    float near = INFINITY, far = -INFINITY;
    for (float r : truth.first_range_m) {
      if (std::isfinite(r)) {
        near = std::min(near, r);
        far = std::max(far, r);
      }
    }
    absl::StrAppend(&text, absl::StrFormat(
                               "\n  ground truth: up to %d returns per pixel, first return at "
                               "%.3f..%.3f m",
                               truth.max_returns, near, far));
  } else {
    absl::StrAppend(&text, "\n  ground truth: none");
  }
  absl::StrAppend(&text, "\n  calibration: ",
                  capture->calibration().has_value() ? "embedded" : "none");
  return text;
}

absl::StatusOr<std::string> DescribeCalibration(const std::string& path) {
  absl::StatusOr<CalibrationTable> table = ReadCalibrationFile(path);
  if (!table.ok()) return table.status();
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(table->schedule);
  const int64_t pixels = table->geometry.pixel_count();
  const int64_t usable = std::count(table->valid.begin(), table->valid.end(), uint8_t{1});
  std::string text = absl::StrFormat(
      "%s: calibration (transient-calibration 1)\n  %dx%d px, %s\n  takes averaged: %d\n  "
      "usable pixels: %d of %d",
      path, table->geometry.width, table->geometry.height,
      schedule.ok() ? schedule->Describe() : "unknown schedule", table->takes_averaged, usable,
      pixels);
  // The median factor per harmonic: its modulus is the relative gain, its angle the phase
  // offset the calibration removes.
  for (int j = 1; j <= table->order; ++j) {
    std::vector<double> modulus, angle;
    for (int64_t p = 0; p < pixels; ++p) {
      if (!table->valid[p]) continue;
      const std::complex<double> k(table->real[j * pixels + p], table->imag[j * pixels + p]);
      modulus.push_back(std::abs(k));
      angle.push_back(std::arg(k));
    }
    if (modulus.empty()) continue;
    absl::StrAppend(&text, absl::StrFormat("\n  k_%d: median |k| %.4g, median arg %.4f rad", j,
                                           Percentile(std::span<double>(modulus), 50.0),
                                           Percentile(std::span<double>(angle), 50.0)));
  }
  return text;
}

absl::StatusOr<std::string> DescribeMoments(const std::string& path) {
  absl::StatusOr<MomentFile> file = MomentFile::Open(path);
  if (!file.ok()) return file.status();
  std::string zeroth = "not stated (measured assumed)";
  if (file->zeroth_hint().has_value()) {
    zeroth = *file->zeroth_hint() == ZerothMoment::kEstimate ? "estimated" : "measured";
  }
  return absl::StrFormat(
      "%s: moments (transient-moments 1)\n  %d frames of %dx%d px, m = %d, f = %s\n  c_0: %s\n  "
      "valid mask: %s, flags: %s",
      path, file->frames(), file->geometry().width, file->geometry().height, file->order(),
      Frequency(file->base_frequency_hz()), zeroth, file->has_valid_mask() ? "yes" : "no",
      file->has_flags() ? "yes" : "no");
}

absl::StatusOr<std::string> DescribeReconstruction(const std::string& path) {
  absl::StatusOr<h5::Id> opened = h5::OpenFileForReading(path, "an HDF5 reconstruction file");
  if (!opened.ok()) return opened.status();
  const hid_t file = opened->get();
  std::string text = absl::StrCat(path, ": reconstruction (transient-reconstruction 1)");
  for (const char* attribute : {"method", "zeroth", "source"}) {
    absl::StatusOr<std::string> value = h5::ReadStringAttribute(file, attribute, path);
    if (value.ok()) absl::StrAppend(&text, "\n  ", attribute, ": ", *value);
  }
  for (const char* attribute : {"base_frequency_hz", "order", "bins", "bias_epsilon"}) {
    absl::StatusOr<double> value = h5::ReadNumericAttribute(file, attribute, path);
    if (value.ok()) absl::StrAppend(&text, "\n  ", attribute, ": ", *value);
  }
  for (const char* dataset :
       {"/range_m", "/c0", "/flags", "/density", "/cumulative", "/pisarenko/phase",
        "/pisarenko/range_m", "/bounds/lower"}) {
    if (!h5::LinkExists(file, dataset)) continue;
    h5::Id id = h5::Dataset(H5Dopen2(file, dataset, H5P_DEFAULT));
    if (!id.valid()) continue;
    h5::Id space = h5::Dataspace(H5Dget_space(id.get()));
    absl::StrAppend(&text, "\n  ", dataset, " ", h5::DimensionsToString(h5::Dimensions(space.get())));
  }
  return text;
}

}  // namespace

absl::StatusOr<std::string> DescribeFile(const std::string& path) {
  absl::StatusOr<FileIdentity> file = IdentifyFile(path);
  if (!file.ok()) return file.status();
  if (!file->named.has_value()) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": format '", file->text,
        "' is none of transient-capture, transient-calibration, transient-moments, "
        "transient-reconstruction"));
  }
  // By name: the reader of that format says what is wrong with another version.
  switch (*file->named) {
    case FileFormat::kCapture:
      return DescribeCapture(path);
    case FileFormat::kCalibration:
      return DescribeCalibration(path);
    case FileFormat::kMoments:
      return DescribeMoments(path);
    case FileFormat::kReconstruction:
      return DescribeReconstruction(path);
  }
  return absl::InternalError(absl::StrCat(path, ": unknown file format"));
}

}  // namespace transient::tools

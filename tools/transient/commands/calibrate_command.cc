// transient calibrate: cycles of a Dirac at zero averaged into per-pixel factors.
#include "tools/transient/commands/calibrate_command.h"

#include <memory>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/drivers/capture_source.h"
#include "transient/formats/atomic_output.h"
#include "transient/formats/calibration_file.h"

namespace transient::tools {
absl::Status CalibrateArgs::Validate() const {
  if (source_uri.empty()) return absl::InvalidArgumentError("--source: expected a source URI");
  if (output_path.empty()) return absl::InvalidArgumentError("--out: expected a file name");
  if (takes < 1 || takes > 256) {
    return absl::InvalidArgumentError(absl::StrCat("--takes = ", takes, ": expected 1..256"));
  }
  return absl::OkStatus();
}

absl::StatusOr<CalibrateSummary> RunCalibrate(const CalibrateArgs& args,
                                              const CommandHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  // The output path is checked before the measurement, not written until it is complete.
  if (absl::Status status = AtomicOutput::Prepare(args.output_path).status(); !status.ok()) {
    return status;
  }
  absl::StatusOr<std::unique_ptr<CaptureSource>> opened = OpenSource(args.source_uri);
  if (!opened.ok()) return opened.status();
  CaptureSource& source = **opened;
  const AcquisitionSchedule& schedule = source.schedule();
  const ImageGeometry geometry = source.camera().geometry;
  absl::StatusOr<CalibrationCapture> measured = CaptureCalibration(
      source, args.takes,
      {.on_take = [&](int done, int total) { hooks.Progress(done, total); },
       .cancel = hooks.cancel});
  if (absl::IsCancelled(measured.status())) {
    return absl::CancelledError("interrupted; no calibration written");
  }
  if (!measured.ok()) return measured.status();
  const CalibrationTable& table = measured->table;
  if (hooks.cancelled()) return absl::CancelledError("interrupted; no calibration written");
  if (absl::Status status = WriteCalibrationFile(args.output_path, table); !status.ok()) {
    return status;
  }

  CalibrateSummary summary{.output_path = args.output_path,
                           .takes_averaged = table.takes_averaged,
                           .frames_rejected = measured->frames_rejected,
                           .usable_pixels = measured->usable_pixels,
                           .pixels = geometry.pixel_count(),
                           .schedule = schedule.Describe()};
  return summary;
}

std::string FormatCalibrateSummary(const CalibrateSummary& s) {
  return absl::StrFormat(
      "%s: calibration from %d takes (%d outlier raw frames left out), %d of %d pixels "
      "usable\n  schedule: %s",
      s.output_path, s.takes_averaged, s.frames_rejected, s.usable_pixels, s.pixels, s.schedule);
}

}  // namespace transient::tools

// A capture's cycles through the frame pipeline, with the calibration the capture asks for.
#include "tools/transient/commands/capture_moments.h"

#include <algorithm>
#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "transient/formats/calibration_file.h"
#include "transient/reconstruct/cycle_assembler.h"

namespace transient::tools {
namespace {

// Dropped cycles listed by name in a summary; the rest are only counted.
constexpr size_t kMaxListedProblems = 5;

}  // namespace

absl::StatusOr<FramePipeline> CapturePipeline(const CaptureReader& capture,
                                              const CaptureMeasureOptions& options,
                                              std::string* calibration_name) {
  if (const ScheduleOptions& schedule = capture.schedule().options(); !schedule.HasAllHarmonics()) {
    return absl::FailedPreconditionError(absl::StrCat(
        capture.path(), ": ", schedule.MissingHarmonicsText("a moment file"),
        "; its range and depth come from transientd --source replay:", capture.path()));
  }
  std::shared_ptr<const CalibrationTable> calibration;
  if (!options.calibration_path.empty()) {
    absl::StatusOr<CalibrationTable> read = ReadCalibrationFile(options.calibration_path);
    if (!read.ok()) return read.status();
    calibration = std::make_shared<const CalibrationTable>(*std::move(read));
    *calibration_name = options.calibration_path;
  } else if (capture.calibration().has_value() && !options.uncalibrated) {
    calibration = std::make_shared<const CalibrationTable>(*capture.calibration());
    *calibration_name = absl::StrCat(capture.path(), ": /calibration");
  } else if (!options.uncalibrated) {
    return absl::InvalidArgumentError(absl::StrCat(
        capture.path(), ": no calibration: pass --calibration FILE (made by transient "
        "calibrate) or --uncalibrated"));
  } else {
    *calibration_name = "none";
  }
  // Measures only; a consumer that solves passes its own options (the defaults here).
  absl::StatusOr<FramePipeline> pipeline = FramePipeline::Create(
      capture.schedule(), capture.camera().geometry,
      MeasureOptions{.calibration = calibration,
                     .smoothing_sigma_px = options.smoothing_sigma_px,
                     .video = options.video},
      SolveOptions{.zeroth = ZerothMomentOf(capture.schedule().options())});
  if (absl::IsFailedPrecondition(pipeline.status())) {
    return absl::FailedPreconditionError(absl::StrCat(
        *calibration_name, " does not fit ", capture.path(), ": ", pipeline.status().message()));
  }
  return pipeline;
}

absl::Status MeasureCapture(const CaptureReader& capture, FramePipeline& pipeline,
                            const CommandHooks& hooks, CaptureMeasureCounts* counts,
                            const std::function<absl::Status(const MomentImage&, double)>& sink) {
  const AcquisitionSchedule& schedule = capture.schedule();
  absl::StatusOr<CycleAssembler> assembler =
      CycleAssembler::Create(schedule, capture.camera().geometry);
  if (!assembler.ok()) return assembler.status();
  auto problem = [&](const absl::Status& status) {
    if (counts->problems.size() < kMaxListedProblems) {
      counts->problems.push_back(std::string(status.message()));
    }
  };
  MomentImage moments;
  RawFrame frame;
  DemodulationReport report;
  for (int64_t i = 0; i < capture.frames(); ++i) {
    if (hooks.cancelled()) return absl::CancelledError("interrupted");
    if (absl::Status status = capture.Read(i, &frame); !status.ok()) {
      ++counts->raw_frames_dropped;  // its cycle is then incomplete and dropped below
      problem(status);
      continue;
    }
    const double timestamp_s = frame.config.timestamp_s;
    absl::StatusOr<bool> complete = assembler->Add(std::move(frame));
    if (!complete.ok()) {
      if (absl::IsDataLoss(complete.status())) ++counts->cycles_dropped;
      problem(complete.status());
    }
    if (!complete.ok() || !*complete) {
      hooks.Progress(i + 1, capture.frames());
      continue;
    }
    std::vector<RawFrame> cycle = assembler->TakeCycle();
    double cycle_start_s = timestamp_s;
    for (const RawFrame& f : cycle) cycle_start_s = std::min(cycle_start_s, f.config.timestamp_s);
    if (absl::Status status = pipeline.Measure(cycle, &moments, &report); !status.ok()) {
      ++counts->cycles_dropped;
      problem(status);
      continue;
    }
    counts->raw_frames_rejected += static_cast<int64_t>(report.rejected.size());
    counts->filled_pixels += report.filled_pixels;
    counts->saturated_pixels += report.saturated_pixels;
    if (absl::Status status = sink(moments, cycle_start_s); !status.ok()) return status;
    ++counts->frames;
    hooks.Progress(i + 1, capture.frames());
  }
  if (assembler->frames_pending() > 0) {
    ++counts->cycles_dropped;
    problem(absl::DataLossError(absl::StrCat(
        "the last transient frame is incomplete (", assembler->frames_pending(), " of ",
        schedule.raw_frames_per_frame(), " raw frames)")));
  }
  counts->raw_frames_dropped += assembler->dropped_frames();
  if (counts->frames == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        capture.path(), ": no complete transient frame among its ", capture.frames(),
        " raw frames (", schedule.raw_frames_per_frame(), " make one: ", schedule.Describe(),
        ")", counts->problems.empty() ? "" : absl::StrCat("; ", counts->problems.front())));
  }
  return absl::OkStatus();
}

}  // namespace transient::tools

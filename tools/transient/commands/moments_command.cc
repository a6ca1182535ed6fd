// transient moments: a capture through the frame pipeline into a moment file.
#include "tools/transient/commands/moments_command.h"

#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tools/transient/commands/capture_moments.h"
#include "transient/formats/atomic_output.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/moment_file_writer.h"
#include "transient/reconstruct/frame_pipeline.h"
#include "transient/reconstruct/smoothing.h"

namespace transient::tools {
absl::Status MomentsArgs::Validate() const {
  if (capture_path.empty()) return absl::InvalidArgumentError("expected a capture file");
  if (output_path.empty()) return absl::InvalidArgumentError("--out: expected a file name");
  if (uncalibrated && !calibration_path.empty()) {
    return absl::InvalidArgumentError("--uncalibrated and --calibration exclude each other");
  }
  if (absl::Status status = ValidateSmoothingSigma(smoothing_sigma_px); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("--smooth: ", status.message()));
  }
  return absl::OkStatus();
}

absl::StatusOr<MomentsSummary> RunMoments(const MomentsArgs& args, const CommandHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  absl::StatusOr<CaptureReader> capture = CaptureReader::Open(args.capture_path);
  if (!capture.ok()) return capture.status();
  const AcquisitionSchedule& schedule = capture->schedule();

  MomentsSummary summary{.output_path = args.output_path};
  absl::StatusOr<FramePipeline> pipeline =
      CapturePipeline(*capture,
                      {.calibration_path = args.calibration_path,
                       .uncalibrated = args.uncalibrated,
                       .smoothing_sigma_px = args.smoothing_sigma_px,
                       .video = args.video},
                      &summary.calibration);
  if (!pipeline.ok()) return pipeline.status();

  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(args.output_path);
  if (!output.ok()) return output.status();
  absl::StatusOr<MomentFileWriter> writer = MomentFileWriter::Create(
      output->temporary_path(),
      MomentFileHeader{.geometry = capture->camera().geometry, .order = schedule.order(),
                       .base_frequency_hz = schedule.options().base_frequency_hz,
                       .zeroth = schedule.options().zeroth, .source = args.capture_path,
                       .calibration = summary.calibration,
                       .smoothing_sigma_px = args.smoothing_sigma_px});
  if (!writer.ok()) return WithFinalPath(writer.status(), args.output_path);

  CaptureMeasureCounts counts;
  absl::Status measured = MeasureCapture(
      *capture, *pipeline, hooks, &counts,
      [&](const MomentImage& moments, double cycle_start_s) {
        return WithFinalPath(writer->Append(moments, cycle_start_s), args.output_path);
      });
  if (absl::IsCancelled(measured)) return absl::CancelledError("interrupted; no moment file written");
  if (!measured.ok()) return measured;
  summary.frames_written = counts.frames;
  summary.cycles_dropped = counts.cycles_dropped;
  summary.raw_frames_dropped = counts.raw_frames_dropped;
  summary.raw_frames_rejected = counts.raw_frames_rejected;
  summary.filled_pixels = counts.filled_pixels;
  summary.saturated_pixels = counts.saturated_pixels;
  summary.problems = std::move(counts.problems);
  if (absl::Status status = writer->Close(); !status.ok()) {
    return WithFinalPath(status, args.output_path);
  }
  if (hooks.cancelled()) return absl::CancelledError("interrupted; no moment file written");
  if (absl::Status status = output->Commit(); !status.ok()) return status;
  return summary;
}

std::string FormatMomentsSummary(const MomentsSummary& s) {
  std::string text = absl::StrFormat(
      "%s: %d transient frames (calibration: %s); %d incomplete or refused frames dropped, %d "
      "outlier raw frames rejected, %d pixels filled from the previous frame, %d saturated",
      s.output_path, s.frames_written, s.calibration, s.cycles_dropped, s.raw_frames_rejected,
      s.filled_pixels, s.saturated_pixels);
  for (const std::string& p : s.problems) absl::StrAppend(&text, "\n  dropped: ", p);
  return text;
}

}  // namespace transient::tools

#include "tools/transient/view/view_inputs.h"

#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "tools/transient/commands/capture_moments.h"
#include "tools/transient/view/view_plan.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/moment_file.h"
#include "transient/reconstruct/frame_pipeline.h"
#include "transient/reconstruct/status_context.h"

namespace transient::tools {
namespace {

// What `transient reconstruct` does by default, with the view's bins and bounds.
ReconstructionSettings ViewSettings(const ViewArgs& args, double base_frequency_hz,
                                    ZerothMoment zeroth) {
  return {.method = Method::kBoth,
          .solve = {.zeroth = zeroth},
          .base_frequency_hz = base_frequency_hz,
          .phases = UniformPhases(args.bins),
          .bounds_r = args.bounds_r};
}

}  // namespace

absl::StatusOr<MomentInput> OpenMomentInput(const ViewArgs& args) {
  absl::StatusOr<MomentFile> file = MomentFile::Open(args.input_path);
  if (!file.ok()) return file.status();
  absl::StatusOr<FrameRange> range = ResolveFrameSlice(args.frames, file->frames());
  if (!range.ok()) return WithContext(args.input_path, range.status());
  ReconstructionSettings settings = ViewSettings(
      args, file->base_frequency_hz(), file->zeroth_hint().value_or(ZerothMoment::kMeasured));
  MomentInput input{.phases = settings.phases, .first_index = range->first};
  input.source = MomentFrameSource::FromFile(args.input_path, *std::move(file), *range,
                                             std::move(settings));
  return input;
}

absl::StatusOr<MomentInput> MeasureCaptureInput(const ViewArgs& args, const CommandHooks& hooks) {
  absl::StatusOr<CaptureReader> capture = CaptureReader::Open(args.input_path);
  if (!capture.ok()) return capture.status();
  if (!capture->calibration().has_value() && args.calibration_path.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        args.input_path, ": a capture without an embedded calibration: give --calibration "
                         "FILE (transient calibrate)"));
  }
  MomentInput input;
  absl::StatusOr<PinholeIntrinsics> intrinsics =
      CaptureIntrinsics(*capture, capture->camera().geometry);
  if (intrinsics.ok()) input.intrinsics = *intrinsics;
  std::string calibration;
  absl::StatusOr<FramePipeline> pipeline =
      CapturePipeline(*capture, {.calibration_path = args.calibration_path}, &calibration);
  if (!pipeline.ok()) return pipeline.status();
  std::vector<MomentImage> frames;
  CaptureMeasureCounts counts;
  absl::Status measured = MeasureCapture(*capture, *pipeline, {.cancel = hooks.cancel}, &counts,
                                         [&](const MomentImage& moments, double) {
                                           frames.push_back(moments);
                                           return absl::OkStatus();
                                         });
  if (absl::IsCancelled(measured)) return absl::CancelledError("interrupted; nothing written");
  if (!measured.ok()) return measured;
  absl::StatusOr<FrameRange> range =
      ResolveFrameSlice(args.frames, static_cast<int64_t>(frames.size()));
  if (!range.ok()) return WithContext(args.input_path, range.status());
  frames.erase(frames.begin() + range->first + range->count, frames.end());
  frames.erase(frames.begin(), frames.begin() + range->first);
  ReconstructionSettings settings =
      ViewSettings(args, capture->schedule().options().base_frequency_hz,
                   ZerothMomentOf(capture->schedule().options()));
  input.phases = settings.phases;
  input.first_index = range->first;
  input.source =
      MomentFrameSource::FromFrames(args.input_path, std::move(frames), std::move(settings));
  return input;
}

}  // namespace transient::tools

#include "transient/drivers/calibration_capture.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "transient/reconstruct/cycle_assembler.h"
#include "transient/reconstruct/demodulation.h"

namespace transient {
namespace {

constexpr absl::Duration kFrameTimeout = absl::Seconds(10);

}  // namespace

absl::StatusOr<CalibrationCapture> CaptureCalibration(CaptureSource& source, int takes,
                                                      const CalibrationCaptureHooks& hooks) {
  if (takes < 1 || takes > 256) {
    return absl::InvalidArgumentError(absl::StrCat("takes = ", takes, ": expected 1..256"));
  }
  const AcquisitionSchedule& schedule = source.schedule();
  const ImageGeometry geometry = source.camera().geometry;
  if (schedule.options().DeliversDepth()) {
    return absl::FailedPreconditionError(absl::StrCat(
        source.uri(), ": ", schedule.options().MissingHarmonicsText("a calibration")));
  }

  // The cycles become takes of one long cycle, so that the demodulator's averaging with
  // outlier rejection (thesis §8.5) treats the whole calibration at once.
  const int source_takes = schedule.options().takes;
  ScheduleOptions combined_options = schedule.options();
  combined_options.takes = takes * source_takes;
  absl::StatusOr<AcquisitionSchedule> combined = AcquisitionSchedule::Create(combined_options);
  if (!combined.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "takes = ", takes, " with ", source_takes,
        " takes per frame of the source exceeds the 1024 takes one calibration can average"));
  }
  absl::StatusOr<Demodulator> demodulator = Demodulator::Create(*combined, geometry, {});
  if (!demodulator.ok()) return demodulator.status();
  absl::StatusOr<CycleAssembler> assembler = CycleAssembler::Create(schedule, geometry);
  if (!assembler.ok()) return assembler.status();

  std::vector<RawFrame> frames;
  frames.reserve(static_cast<size_t>(combined->raw_frames_per_frame()));
  if (absl::Status status = source.Start(); !status.ok()) return status;
  int cycles = 0;
  RawFrame frame;
  while (cycles < takes) {
    if (hooks.cancel != nullptr && hooks.cancel->load()) {
      (void)source.Stop();
      return absl::CancelledError("calibration interrupted");
    }
    absl::Status next = source.Next(kFrameTimeout, &frame);
    if (absl::IsOutOfRange(next)) {
      (void)source.Stop();
      return absl::InvalidArgumentError(absl::StrCat(source.uri(), ": ended after ", cycles,
                                                     " complete frames; ", takes,
                                                     " takes were asked for"));
    }
    if (!next.ok()) {
      (void)source.Stop();
      return next;
    }
    absl::StatusOr<bool> complete = assembler->Add(std::move(frame));
    if (!complete.ok() || !*complete) continue;  // an incomplete cycle is dropped, not used
    for (RawFrame& f : assembler->TakeCycle()) {
      f.config.take += cycles * source_takes;
      f.config.cycle = 0;
      frames.push_back(std::move(f));
    }
    ++cycles;
    if (hooks.on_take) hooks.on_take(cycles, takes);
  }
  (void)source.Stop();

  MomentImage moments;
  DemodulationReport report;
  if (absl::Status status = demodulator->Demodulate(frames, &moments, &report); !status.ok()) {
    return status;
  }
  absl::StatusOr<CalibrationTable> table = EstimateCalibration(
      moments, schedule.options(),
      report.frames_used / std::max(1, schedule.exposures_per_take()));
  if (!table.ok()) return table.status();
  CalibrationCapture result{.table = *std::move(table),
                            .frames_rejected = static_cast<int>(report.rejected.size())};
  result.usable_pixels = std::count(result.table.valid.begin(), result.table.valid.end(),
                                    uint8_t{1});
  return result;
}

}  // namespace transient

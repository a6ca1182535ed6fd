// Measure (demodulate, calibrate, smooth) and Solve (zeroth moment, bias, Levinson) of one frame.
#include "transient/reconstruct/frame_pipeline.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "transient/reconstruct/smoothing.h"

namespace transient {

absl::Status MeasureOptions::Validate() const {
  if (absl::Status status = ValidateSmoothingSigma(smoothing_sigma_px); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("smoothing_sigma_px: ", status.message()));
  }
  return absl::OkStatus();
}

ZerothMoment ZerothMomentOf(const ScheduleOptions& schedule) {
  return schedule.zeroth == ZerothScheme::kEstimated ? ZerothMoment::kEstimate
                                                     : ZerothMoment::kMeasured;
}

absl::StatusOr<FramePipeline> FramePipeline::Create(const AcquisitionSchedule& schedule,
                                                    ImageGeometry geometry,
                                                    const MeasureOptions& measure,
                                                    const SolveOptions& solve) {
  if (absl::Status status = measure.Validate(); !status.ok()) return status;
  if (absl::Status status = solve.Validate(); !status.ok()) return status;
  if (measure.calibration != nullptr) {
    if (absl::Status status =
            CheckCalibrationMatches(*measure.calibration, schedule.options(), geometry);
        !status.ok()) {
      return status;
    }
  }
  absl::StatusOr<Demodulator> demodulator =
      Demodulator::Create(schedule, geometry, DemodulationOptions{.video = measure.video});
  if (!demodulator.ok()) return demodulator.status();
  return FramePipeline(*std::move(demodulator), measure, solve);
}

FramePipeline::FramePipeline(Demodulator demodulator, MeasureOptions measure, SolveOptions solve)
    : demodulator_(std::move(demodulator)), measure_(std::move(measure)), solve_(solve) {
  const ScheduleOptions& schedule = demodulator_.schedule().options();
  if (!schedule.HasAllHarmonics()) {
    smoothed_planes_ = schedule.MeasuredHarmonics();
    smoothed_planes_.insert(smoothed_planes_.begin(), 0);
  }
}

absl::Status FramePipeline::Measure(std::span<const RawFrame> cycle, MomentImage* moments,
                                    DemodulationReport* report) {
  if (absl::Status status = demodulator_.Demodulate(cycle, moments, report); !status.ok()) {
    return status;
  }
  if (measure_.calibration != nullptr) {
    if (absl::Status status = ApplyCalibration(*measure_.calibration, moments); !status.ok()) {
      return status;
    }
  }
  // A harmonic set's other planes are zeros: only c_0 and the measured ones are smoothed.
  return GaussianSmooth(measure_.smoothing_sigma_px, moments, smoothed_planes_);
}

absl::Status FramePipeline::SetCalibration(std::shared_ptr<const CalibrationTable> calibration) {
  if (calibration != nullptr) {
    if (absl::Status status =
            CheckCalibrationMatches(*calibration, schedule().options(), geometry());
        !status.ok()) {
      return status;
    }
  }
  measure_.calibration = std::move(calibration);
  return absl::OkStatus();
}

void FramePipeline::Solve(const MomentImage& moments, SolvedImage* solved) const {
  transient::Solve(moments, solve_, solved);
}

}  // namespace transient

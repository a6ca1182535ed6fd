// One transient frame's way through the reconstruction (DESIGN.md, "The data path", steps 2-4):
// the one path of transientd, `transient moments`, `transient reconstruct` and `transient view`.
//
//   a capture cycle of raw frames --Measure--> moments c_0..c_m --Solve--> solved state
//
// Measure: demodulation (four-bucket phasors divided by the sub-exposure gain, takes averaged
// with outlier rejection, video fill; thesis §8.3, §8.5), calibration against a Dirac at zero
// (§8.3.2) and Gaussian smoothing (σ = 0.6 px by default, §8.5). Solve: the zeroth moment
// (measured or estimated from λ_min), biasing to λ_min ≥ ε·c_0 (§8.3.3) and Levinson's
// algorithm (alg. 8.1). The products of a solved frame are frame_products.h's.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/calibration.h"
#include "transient/reconstruct/demodulation.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient {

// How raw frames become moments.
struct MeasureOptions {
  std::shared_ptr<const CalibrationTable> calibration = nullptr;  // nullptr: uncalibrated
  double smoothing_sigma_px = 0.6;  // thesis §8.5; 0 = none
  bool video = false;               // fill an outlier capture from the previous frame (§8.5)

  // "smoothing_sigma_px: ..." naming the rule.
  absl::Status Validate() const;
};

// The zeroth moment a schedule yields: measured, or estimated when it has no zeroth exposures.
ZerothMoment ZerothMomentOf(const ScheduleOptions& schedule);

class FramePipeline {
 public:
  // InvalidArgument for bad options; FailedPrecondition naming both values when the calibration
  // does not fit the schedule or the geometry (CheckCalibrationMatches).
  [[nodiscard]] static absl::StatusOr<FramePipeline> Create(const AcquisitionSchedule& schedule,
                                                            ImageGeometry geometry,
                                                            const MeasureOptions& measure,
                                                            const SolveOptions& solve);

  // A complete capture cycle (CycleAssembler::TakeCycle) into calibrated, smoothed moments,
  // reusing `moments`' buffers. The demodulator's InvalidArgument for a frame that does not
  // belong or an exposure that is missing; then `moments` is unspecified and the next cycle is
  // measured as if this one had not come. `report`, when given, says what was rejected.
  absl::Status Measure(std::span<const RawFrame> cycle, MomentImage* moments,
                       DemodulationReport* report = nullptr);

  // Moments (Measure's, or a moment file's) into the solved state, reusing `solved`'s
  // buffers. `moments` must pass MomentImage::Validate() (asserted).
  void Solve(const MomentImage& moments, SolvedImage* solved) const;

  // Measures with `calibration` (nullptr: none) from the next cycle on, keeping the video
  // history. FailedPrecondition as Create when it does not fit; then nothing changes.
  absl::Status SetCalibration(std::shared_ptr<const CalibrationTable> calibration);

  const AcquisitionSchedule& schedule() const { return demodulator_.schedule(); }
  ImageGeometry geometry() const { return demodulator_.geometry(); }
  const MeasureOptions& measure_options() const { return measure_; }
  const SolveOptions& solve_options() const { return solve_; }

 private:
  FramePipeline(Demodulator demodulator, MeasureOptions measure, SolveOptions solve);

  Demodulator demodulator_;
  MeasureOptions measure_;
  SolveOptions solve_;
  std::vector<int> smoothed_planes_;  // empty: all (1..m measured)
};

}  // namespace transient

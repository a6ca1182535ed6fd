// Demodulation (thesis §8.3): turns the raw frames of one capture cycle into the trigonometric
// moments c_0..c_m of every pixel, averaging takes with outlier rejection and, in video mode,
// filling outlier captures from the previous cycle (thesis §8.5).
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/image.h"

namespace transient {

struct DemodulationOptions {
  // Rejection of outlier takes (thesis §8.5: 5-10 % of captures of the prototype differ
  // significantly from the others of the same configuration). With takes >= 3, per exposure,
  // each take's score is the median over pixels of |frame - per-pixel median over takes|; a
  // take whose score exceeds outlier_threshold * max(median score, floor) is not averaged.
  // With 1 or 2 takes nothing is rejected this way (two disagreeing frames cannot tell which is
  // the outlier): both are averaged.
  bool reject_outliers = true;
  double outlier_threshold = 5.0;  // > 1
  // The floor keeps noise-free or nearly noise-free data from rejecting on rounding: a fraction
  // of the median |value| of the exposure (its typical offset plus signal), in [0, 1).
  double outlier_relative_floor = 1e-3;

  // Video mode: keep the previous cycle. A frame whose score (median over pixels of |frame -
  // previous cycle's average of the same exposure|) is above video_threshold times its recent
  // typical score (median of the last video_history accepted scores of that exposure), and
  // above video_threshold times the median such ratio over the cycle's frames (so that scene
  // motion, which raises all scores together, rejects nothing), is rejected. When every take of
  // an exposure is rejected, the moment plane it feeds (its harmonic, or c_0) is copied from the
  // previous cycle's output and all pixels get kFlagOutlierFilled. Nothing can be rejected
  // before the exposure has kMinVideoScores scores (from the fourth cycle on with one take); an
  // outlier accepted before then is the next cycle's reference for its exposure.
  bool video = false;
  double video_threshold = 5.0;  // > 1
  int video_history = 8;         // kMinVideoScores <= video_history <= 1024
  // After this many consecutive fills of one exposure its frames are accepted again, so that a
  // lasting change (a new exposure gain) cannot freeze a plane forever. >= 1.
  int video_max_consecutive_fills = 3;

  // Names the first violated constraint, e.g. "outlier_threshold = 0.5. Violated constraint:
  // outlier_threshold > 1".
  absl::Status Validate() const;
};

// Video mode needs this many recent scores of an exposure before it can reject its frames.
inline constexpr int kMinVideoScores = 3;

// What one Demodulate call did.
struct DemodulationReport {
  int64_t cycle = 0;
  int frames_used = 0;                   // raw frames averaged into the output
  std::vector<ExposureConfig> rejected;  // outlier frames not used (takes or video)
  std::vector<int> filled_planes;        // moment planes j copied from the previous cycle
  int64_t saturated_pixels = 0;          // pixels invalid because a used frame saturated
  int64_t filled_pixels = 0;             // pixels flagged kFlagOutlierFilled
};

// Demodulates complete capture cycles of one AcquisitionSchedule on one sensor geometry.
//
// Convention (the contract with the sources, drivers/): an exposure of harmonic j with bucket
// phase shift beta measures, per pixel, M(beta) = offset + Re(exp(-i*beta) * g * c_j) with
// g = schedule.nominal_gain() = sum_k w_k exp(-i*theta_k) over the sub-exposures. The N-step
// phasor Z = (2/N) sum_k M(2*pi*k/N) exp(i*2*pi*k/N) equals g*c_j (for N = 4 the four-bucket
// Z = (M(0) - M(pi))/2 + i*(M(pi/2) - M(3pi/2))/2), so c_j = Z / g (thesis §8.3.1: four-bucket differences cancel the offset and even harmonics;
// arccos sampling, eq. 8.7, and harmonic cancellation make the rest sinusoidal). c_0:
//  - kUnmodulatedPair: c_0 = M(illumination on) - M(illumination off), both unmodulated;
//  - kLowFrequencyProxy: c_0 = |Z / g| of the N buckets at the proxy frequency. The modulus
//    needs no phase calibration; for returns within r metres it underestimates c_0 by a
//    factor of at most 1 - cos(2*pi*f_proxy*2r/c) (thesis §8.3.3: 900 kHz, 333 m wavelength);
//  - kEstimated: plane 0 holds 0; solve with ZerothMoment::kEstimate.
// Planes of harmonics the schedule does not measure (ScheduleOptions::harmonics) hold 0.
// Output moments are uncalibrated (apply calibration.h next). A pixel that is NaN or at or above
// its frame's saturation_level in any frame used is invalid (valid = 0, kFlagSaturated) and holds
// NaN in every plane.
class Demodulator {
 public:
  // InvalidArgument when the geometry is empty or `options` fails Validate(); FailedPrecondition
  // for a depth camera's schedule (SamplingScheme::kDepth), which has nothing to demodulate.
  [[nodiscard]] static absl::StatusOr<Demodulator> Create(const AcquisitionSchedule& schedule,
                                                          ImageGeometry geometry,
                                                          const DemodulationOptions& options);

  // Demodulates one complete cycle: every exposure of schedule().exposures() (all takes)
  // exactly once, in any order, all with the same cycle index. InvalidArgument naming the
  // frame (sequence and DescribeExposure) when one is foreign to the schedule, duplicated, of
  // another cycle than the first frame, of another geometry or pixel count, and naming the
  // exposures when some are missing; then `out` and the video history are unchanged.
  // `out` is overwritten (its buffers reused) with order m, valid and flags planes.
  absl::Status Demodulate(std::span<const RawFrame> cycle, MomentImage* out,
                          DemodulationReport* report = nullptr);

  // Forgets the previous cycle (video mode), e.g. after a gap in the stream.
  void ResetHistory();

  const AcquisitionSchedule& schedule() const { return schedule_; }
  ImageGeometry geometry() const { return geometry_; }
  const DemodulationOptions& options() const { return options_; }

 private:
  // Video-mode memory of one exposure (position within a take).
  struct ExposureHistory {
    std::vector<float> previous_samples;  // previous cycle's average at sample_pixels_
    std::deque<double> scores;            // recent accepted scores, newest last
    double score_floor = 0.0;             // outlier_relative_floor * median |previous_samples|
    int consecutive_fills = 0;
  };

  Demodulator(const AcquisitionSchedule& schedule, ImageGeometry geometry,
              const DemodulationOptions& options);

  // Orders the frames by schedule index into slots_; the error names the offending frame.
  absl::Status IndexFrames(std::span<const RawFrame> cycle);
  // Clears accepted_ for the outlier takes of exposure `e` (takes >= 3).
  void RejectOutlierTakes(int e);
  // Scores every accepted frame against the previous cycle and clears accepted_ for outliers.
  void RejectVideoOutliers();
  // Where the mean of the accepted takes of exposure `e` lies: the single take's pixels, or
  // averages_[e] (sized here) for AverageExposure to fill.
  const float* ExposureAverage(int e);
  // The mean of the accepted takes of exposure `e` into averages_[e] over pixels [begin, end)
  // where it has several; ORs the pixels that are NaN or saturated in a used frame into bad_.
  void AverageExposure(int e, int64_t begin, int64_t end);
  // Remembers the accepted frames' sample averages and scores of the exposures not filled.
  void UpdateVideoHistory(const std::vector<bool>& exposure_filled);

  AcquisitionSchedule schedule_;
  ImageGeometry geometry_;
  DemodulationOptions options_;
  int exposures_per_take_ = 0;
  int takes_ = 1;
  Complex inverse_gain_{1.0, 0.0};
  std::vector<int> exposure_plane_;  // moment plane j fed by exposure e (within a take)
  // Exposure (within a take) of plane j's bucket k (phase shift 2*pi*k/N), or of c_0's
  // illumination-on ([0][0]) and -off ([0][1]) pair; -1 where the schedule has none (planes of
  // harmonics it does not measure).
  std::vector<std::array<int, kMaxPhaseBuckets>> plane_exposures_;
  // (2/N) exp(i*2*pi*k/N): bucket k's share of the N-step phasor.
  std::vector<float> bucket_cos_, bucket_sin_;
  std::vector<int64_t> sample_pixels_;  // pixels the robust scores look at

  // Per-call scratch, kept to reuse allocations.
  std::vector<const RawFrame*> slots_;  // by schedule index
  std::vector<bool> accepted_;          // by schedule index
  std::vector<std::vector<float>> averages_;
  std::vector<uint8_t> bad_;
  std::vector<float> scratch_;
  std::vector<double> score_scratch_;
  std::vector<double> video_scores_;  // by schedule index; NaN where not scored

  // Video mode.
  bool have_previous_ = false;
  MomentImage previous_;
  std::vector<ExposureHistory> history_;
};

}  // namespace transient

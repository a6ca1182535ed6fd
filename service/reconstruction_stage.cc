// One capture cycle through the frame pipeline into the products of a published frame.
#include "reconstruction_stage.h"

#include <atomic>
#include <span>
#include <utility>

#include "absl/strings/str_cat.h"

namespace transient::service {
namespace {

// Solved images kept for reuse: enough for the frames subscribers' queues and Latest() hold.
constexpr size_t kSolvedPoolSize = 8;

}  // namespace

absl::StatusOr<std::shared_ptr<const FrameProducts>> ReconstructionStage::RunDepth(
    const CycleItem& cycle, const ReconstructionInputs& inputs) {
  const ScheduleOptions& schedule = cycle.schedule->options();
  if (inputs.calibration != nullptr) {  // Pipeline::Create and Calibrate refuse one already
    return absl::FailedPreconditionError(
        schedule.MissingHarmonicsText("a calibration table (per-pixel factors of the moments)"));
  }
  const size_t expected = schedule.depth_amplitude ? 2 : 1;
  const size_t pixels = static_cast<size_t>(camera_.geometry.pixel_count());
  if (cycle.frames.size() != expected) {
    return absl::InvalidArgumentError(absl::StrCat("a depth camera's cycle of ",
                                                   cycle.frames.size(), " frames; expected ",
                                                   expected, " (", cycle.schedule->Describe(), ")"));
  }
  for (const RawFrame& frame : cycle.frames) {
    if (frame.pixels.size() != pixels) {
      return absl::InvalidArgumentError(absl::StrCat(DescribeFrame(frame.config), " has ",
                                                     frame.pixels.size(), " pixels; expected ",
                                                     pixels));
    }
  }
  // The assembler delivers the cycle in schedule order: depth, then amplitude.
  const std::span<const float> amplitude =
      schedule.depth_amplitude ? std::span<const float>(cycle.frames[1].pixels)
                               : std::span<const float>();
  return ComputeDepthProducts(cycle.frames[0].pixels, amplitude, camera_, inputs.needs,
                              sequence_++, &moment_depth_builders_);
}

std::shared_ptr<SolvedImage> ReconstructionStage::RecycledSolvedImage() {
  for (const auto& candidate : solved_pool_) {
    // Only the pool holds it: no published frame (nor Latest()) can reach it any more.
    if (candidate.use_count() == 1) {
      // Orders our writes after the last reader's release of its reference.
      std::atomic_thread_fence(std::memory_order_acquire);
      return candidate;
    }
  }
  auto solved = std::make_shared<SolvedImage>();
  if (solved_pool_.size() < kSolvedPoolSize) solved_pool_.push_back(solved);
  return solved;
}

absl::StatusOr<std::shared_ptr<const FrameProducts>> ReconstructionStage::Run(
    const CycleItem& cycle, const ReconstructionInputs& inputs) {
  const ReconstructionConfig& config = inputs.config;
  if (cycle.schedule->options().DeliversDepth()) return RunDepth(cycle, inputs);
  if (schedule_ != cycle.schedule || config_version_ != inputs.config_version) {
    absl::StatusOr<FramePipeline> created = FramePipeline::Create(
        *cycle.schedule, cycle.frames.front().geometry,
        MeasureOptions{.calibration = inputs.calibration,
                       .smoothing_sigma_px = config.smoothing_sigma_px,
                       .video = config.video},
        SolveOptions{.bias_epsilon = config.bias_epsilon,
                     .zeroth = ZerothMomentOf(cycle.schedule->options())});
    if (!created.ok()) return created.status();
    pipeline_.emplace(*std::move(created));
    schedule_ = cycle.schedule;
    config_version_ = inputs.config_version;
  }
  if (pipeline_->measure_options().calibration != inputs.calibration) {
    // Calibrate applied a new one.
    if (absl::Status status = pipeline_->SetCalibration(inputs.calibration); !status.ok()) {
      return status;
    }
  }
  if (absl::Status status = pipeline_->Measure(cycle.frames, &moments_, &report_);
      !status.ok()) {
    return status;
  }
  const ScheduleOptions& schedule = cycle.schedule->options();
  if (!schedule.HasAllHarmonics()) {
    // A camera's fixed frequencies (the Kinect v2): no moment reconstruction, range by
    // unwrapping; the subscriptions that need more were refused (PlanStream).
    const UnwrapOptions unwrap{.base_frequency_hz = schedule.base_frequency_hz,
                               .harmonics = schedule.MeasuredHarmonics()};
    return ComputeUnwrappedProducts(moments_, camera_, unwrap, inputs.needs, sequence_++,
                                    &moment_depth_builders_);
  }
  std::shared_ptr<SolvedImage> solved = RecycledSolvedImage();
  pipeline_->Solve(moments_, solved.get());
  const ProductOptions options{.base_frequency_hz = cycle.schedule->options().base_frequency_hz,
                               .range_method = config.range_method,
                               .threshold = config.threshold};
  return ComputeProducts(std::move(solved), camera_, options, inputs.needs, sequence_++,
                         &moment_depth_builders_);
}

}  // namespace transient::service

// The daemon's reconstruction thread's work on one capture cycle (DESIGN.md, "The data path",
// steps 2-4): the frame pipeline (measure, solve) rebuilt when the schedule or the settings
// change, and the products every subscriber asked for, computed once into an immutable frame.
// The per-pixel solved state is recycled once no published frame holds it any more: at
// 640x480 a fresh one cost ~50 MB of page faults per frame; so are the moment depth maps'
// builders.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "cycle_queue.h"
#include "transient/reconstruct/calibration.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/frame_pipeline.h"
#include "transient/reconstruct/frame_products.h"
#include "transient/service/reconstruction_config.h"

namespace transient::service {

// Everything one cycle's reconstruction depends on, read under the pipeline's lock.
struct ReconstructionInputs {
  ReconstructionConfig config;
  uint64_t config_version = 0;  // a new version rebuilds the frame pipeline
  std::shared_ptr<const CalibrationTable> calibration;  // may change between cycles
  ProductNeeds needs;
};

class ReconstructionStage {
 public:
  explicit ReconstructionStage(CameraInfo camera) : camera_(std::move(camera)) {}

  // Measures, solves and computes the products of `cycle`. A cycle the pipeline refuses (its
  // schedule, its frames, a calibration that does not fit) is InvalidArgument or
  // FailedPrecondition naming why; the next cycle is reconstructed as if it had not come.
  absl::StatusOr<std::shared_ptr<const FrameProducts>> Run(const CycleItem& cycle,
                                                           const ReconstructionInputs& inputs);
  // Outlier raw frames left out of the last frame (thesis §8.5).
  int64_t rejected_frames() const { return static_cast<int64_t>(report_.rejected.size()); }

 private:
  // A depth camera's cycle (SamplingScheme::kDepth): no demodulation, the products of the
  // given depth (ComputeDepthProducts). InvalidArgument for a cycle of the wrong shape.
  absl::StatusOr<std::shared_ptr<const FrameProducts>> RunDepth(const CycleItem& cycle,
                                                                const ReconstructionInputs& inputs);
  // A solved image no published frame holds any more, or a new one.
  std::shared_ptr<SolvedImage> RecycledSolvedImage();

  const CameraInfo camera_;
  std::shared_ptr<const AcquisitionSchedule> schedule_;
  uint64_t config_version_ = ~uint64_t{0};
  std::optional<FramePipeline> pipeline_;
  MomentImage moments_;
  DemodulationReport report_;
  uint64_t sequence_ = 0;
  std::vector<std::shared_ptr<SolvedImage>> solved_pool_;
  // Kept across frames: their VGA-sized buffers are allocated once per spec, not per frame.
  MomentDepthBuilders moment_depth_builders_;
};

}  // namespace transient::service

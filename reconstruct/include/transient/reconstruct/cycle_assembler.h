// Groups a stream of raw frames, as a source delivers them, into complete capture cycles for the
// demodulator (demodulation.h), recovering from lost, foreign and duplicated frames.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/image.h"

namespace transient {

// Collects the frames of one cycle (all exposures of the schedule, all takes) at a time.
// Frames of a cycle may arrive in any order; cycles are assumed to arrive in increasing order of
// ExposureConfig::cycle. Not thread-safe.
class CycleAssembler {
 public:
  // InvalidArgument when the geometry is empty.
  [[nodiscard]] static absl::StatusOr<CycleAssembler> Create(const AcquisitionSchedule& schedule,
                                                             ImageGeometry geometry);

  // Adds one frame. Returns true when it completed a cycle; take it with TakeCycle() before the
  // next Add. Errors (the frame, or the cycle, is dropped and counted; the stream goes on):
  //  - InvalidArgument naming the frame: another geometry or pixel count, not an exposure of the
  //    schedule, a duplicate of a frame of the current cycle, or of an older cycle;
  //  - DataLoss naming the missing exposures: a frame of a newer cycle arrived while the current
  //    one is incomplete. The incomplete cycle is dropped and the new one starts with this frame;
  //  - FailedPrecondition: a complete cycle is waiting for TakeCycle(); the frame is dropped.
  absl::StatusOr<bool> Add(RawFrame frame);

  // The completed cycle in schedule order (AcquisitionSchedule::exposures()), or an empty vector
  // when none is complete. The assembler then waits for the next cycle.
  std::vector<RawFrame> TakeCycle();

  bool cycle_ready() const { return ready_; }
  // Cycle index being assembled (or ready), if any frame of it has arrived.
  std::optional<int64_t> current_cycle() const { return current_cycle_; }
  int frames_pending() const { return received_; }
  // Frames refused or lost with a dropped cycle, and incomplete cycles dropped, since Create.
  int64_t dropped_frames() const { return dropped_frames_; }
  int64_t dropped_cycles() const { return dropped_cycles_; }

  // Drops the cycle being assembled (counted), e.g. when the source restarts.
  void Reset();

 private:
  CycleAssembler(const AcquisitionSchedule& schedule, ImageGeometry geometry);
  void DropCurrent();

  AcquisitionSchedule schedule_;
  ImageGeometry geometry_;
  std::vector<std::optional<RawFrame>> slots_;  // by schedule index
  int received_ = 0;
  bool ready_ = false;
  std::optional<int64_t> current_cycle_;
  int64_t last_completed_cycle_ = -1;
  bool have_completed_ = false;
  int64_t dropped_frames_ = 0;
  int64_t dropped_cycles_ = 0;
};

}  // namespace transient

// The queue between the daemon's source thread and its reconstruction thread (DESIGN.md,
// "Threads"): complete capture cycles and state changes, in order. It holds at most `capacity`
// cycles: a live source that outruns the reconstruction drops the oldest cycle (counted); a
// source that waits for its consumer (a replay at pace=fast) waits for room instead, so that no
// recorded frame is lost.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/service/subscription.h"

namespace transient::service {

// A complete capture cycle, or a state change of the source (an announcement).
struct CycleItem {
  std::vector<RawFrame> frames;
  std::shared_ptr<const AcquisitionSchedule> schedule;
  absl::Time arrival;  // when the cycle's last raw frame came from the source
  bool announcement = false;
  SourceState state = SourceState::kStreaming;
};

class CycleQueue {
 public:
  // Announcements take no room (the bound is on cycles) and are never dropped for cycles; of a
  // burst of them (a source failing again and again) only the latest kMaxAnnouncements stay.
  static constexpr size_t kMaxAnnouncements = 8;

  explicit CycleQueue(int capacity) : capacity_(static_cast<size_t>(capacity < 1 ? 1 : capacity)) {}

  // Whether Push waits for room rather than dropping the oldest cycle.
  void set_wait_for_room(bool wait) ABSL_LOCKS_EXCLUDED(mu_);

  // Appends `item`; returns the number of cycles dropped to make room. After Close() it does
  // nothing (a waiting Push returns then too).
  int Push(CycleItem item) ABSL_LOCKS_EXCLUDED(mu_);

  // The oldest item, waiting at most `timeout`; nullopt on timeout and once closed.
  std::optional<CycleItem> Pop(absl::Duration timeout) ABSL_LOCKS_EXCLUDED(mu_);

  // Wakes every waiter; from now on Push and Pop do nothing.
  void Close() ABSL_LOCKS_EXCLUDED(mu_);

 private:
  size_t CyclesQueued() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const size_t capacity_;
  absl::Mutex mu_;
  std::deque<CycleItem> items_ ABSL_GUARDED_BY(mu_);
  bool wait_for_room_ ABSL_GUARDED_BY(mu_) = false;
  bool closed_ ABSL_GUARDED_BY(mu_) = false;
};

}  // namespace transient::service

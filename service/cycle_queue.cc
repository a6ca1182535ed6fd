// The bounded queue of capture cycles between the source and reconstruction threads.
#include "cycle_queue.h"

#include <algorithm>
#include <utility>

namespace transient::service {
namespace {

bool IsAnnouncement(const CycleItem& item) { return item.announcement; }
bool IsCycle(const CycleItem& item) { return !item.announcement; }

}  // namespace

void CycleQueue::set_wait_for_room(bool wait) {
  absl::MutexLock lock(&mu_);
  wait_for_room_ = wait;
}

size_t CycleQueue::CyclesQueued() const {
  return static_cast<size_t>(std::count_if(items_.begin(), items_.end(), IsCycle));
}

int CycleQueue::Push(CycleItem item) {
  absl::MutexLock lock(&mu_);
  if (closed_) return 0;
  if (item.announcement) {
    while (std::count_if(items_.begin(), items_.end(), IsAnnouncement) >=
           static_cast<ptrdiff_t>(kMaxAnnouncements)) {
      items_.erase(std::find_if(items_.begin(), items_.end(), IsAnnouncement));
    }
    items_.push_back(std::move(item));
    return 0;
  }
  if (wait_for_room_) {
    auto room = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
      return closed_ || CyclesQueued() < capacity_;
    };
    mu_.Await(absl::Condition(&room));
    if (closed_) return 0;
  }
  int dropped = 0;
  while (CyclesQueued() >= capacity_) {
    items_.erase(std::find_if(items_.begin(), items_.end(), IsCycle));
    ++dropped;
  }
  items_.push_back(std::move(item));
  return dropped;
}

std::optional<CycleItem> CycleQueue::Pop(absl::Duration timeout) {
  absl::MutexLock lock(&mu_);
  auto ready = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return closed_ || !items_.empty(); };
  mu_.AwaitWithTimeout(absl::Condition(&ready), timeout);
  if (closed_ || items_.empty()) return std::nullopt;
  CycleItem item = std::move(items_.front());
  items_.pop_front();
  return item;
}

void CycleQueue::Close() {
  absl::MutexLock lock(&mu_);
  closed_ = true;
}

}  // namespace transient::service

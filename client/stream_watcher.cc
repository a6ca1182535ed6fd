// StreamWatcher: a thread that polls the cancel flag and the clock.
#include "stream_watcher.h"

#include <algorithm>

namespace transient::client {
namespace {

// How often the watcher looks at the cancel flag and the clock: well below what a person
// notices after Ctrl-C, and cheap.
constexpr absl::Duration kWatchPeriod = absl::Milliseconds(20);

}  // namespace

StreamWatcher::StreamWatcher(grpc::ClientContext* context, const std::atomic<bool>* cancel,
                             absl::Time deadline)
    : thread_([this, context, cancel, deadline] { Watch(context, cancel, deadline); }) {}

StreamWatcher::~StreamWatcher() {
  stop_.Notify();
  thread_.join();
}

void StreamWatcher::Watch(grpc::ClientContext* context, const std::atomic<bool>* cancel,
                          absl::Time deadline) {
  while (!stop_.WaitForNotificationWithTimeout(
      std::min(kWatchPeriod, std::max(deadline - absl::Now(), absl::ZeroDuration())))) {
    Reason reason = Reason::kNone;
    if (cancel != nullptr && cancel->load()) {
      reason = Reason::kInterrupted;
    } else if (absl::Now() >= deadline) {
      reason = Reason::kTimeUp;
    }
    if (reason != Reason::kNone) {
      reason_.store(reason);
      context->TryCancel();
      return;
    }
  }
}

}  // namespace transient::client

// Cancels a gRPC call from a second thread when a cancel flag turns true or a deadline passes:
// a blocking Read() only returns when a message arrives or the call ends. Private to the
// client library (FrameStream, Client::Calibrate).
#pragma once

#include <grpcpp/client_context.h>

#include <atomic>
#include <thread>

#include "absl/synchronization/notification.h"
#include "absl/time/time.h"

namespace transient::client {

class StreamWatcher {
 public:
  enum class Reason { kNone, kInterrupted, kTimeUp };

  // Watches until destroyed; `context` must outlive this object, `cancel` may be null.
  StreamWatcher(grpc::ClientContext* context, const std::atomic<bool>* cancel,
                absl::Time deadline);
  StreamWatcher(const StreamWatcher&) = delete;
  StreamWatcher& operator=(const StreamWatcher&) = delete;
  ~StreamWatcher();

  // Why it cancelled the call; kNone while it has not.
  Reason reason() const { return reason_.load(); }

 private:
  void Watch(grpc::ClientContext* context, const std::atomic<bool>* cancel, absl::Time deadline);

  absl::Notification stop_;
  std::atomic<Reason> reason_{Reason::kNone};
  std::thread thread_;  // last: it starts once the members it uses exist
};

}  // namespace transient::client

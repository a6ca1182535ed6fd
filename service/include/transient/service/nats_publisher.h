// The daemon's NATS publisher (`transientd --publish nats://...`; README, "Many cameras, many
// machines"): a subscriber of the pipeline like a gRPC stream, with its own bounded queue and
// thread, that publishes each frame's products to `transient.<camera>.<product>` through
// JetStream (wire/nats.h), into the stream TRANSIENT_<camera> with the limits it is given.
//
// It never stalls the camera or the gRPC subscribers: a slow NATS side loses its own oldest
// frames (counted as behind), frames while the server is unreachable are dropped and counted,
// and at most `max_pending` messages wait for JetStream's acknowledgement.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "transient/service/pipeline.h"
#include "transient/service/stream_plan.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/nats.h"

namespace transient::service {

struct NatsPublishOptions {
  wire::NatsConnectOptions connect;
  std::string camera = "camera";  // subjects transient.<camera>.<product>
  // What is published, encoded as a gRPC stream of the same request would be; no products =
  // MOMENT_STATE, the state every other product is computed from.
  v1::StreamRequest request;
  // The JetStream stream's limits: frames older than max_age or beyond max_bytes are removed
  // (oldest first); zero = no limit of that kind.
  absl::Duration max_age = absl::Hours(1);
  int64_t max_bytes = int64_t{1} << 30;
  int replicas = 1;       // copies kept by a cluster's servers (1..5)
  int max_pending = 256;  // messages published and not yet acknowledged, at most
};

// What the publisher did since it started.
struct NatsPublishStats {
  std::string servers;
  std::string camera;
  bool connected = false;
  uint64_t frames_published = 0;  // every message of the frame handed to NATS
  uint64_t messages_published = 0;
  uint64_t messages_acknowledged = 0;        // stored by JetStream
  uint64_t messages_failed = 0;              // refused or unacknowledged within the wait
  uint64_t frames_dropped_disconnected = 0;  // no server reachable
  uint64_t frames_dropped_behind = 0;        // the NATS side fell behind the camera (its queue)
  uint64_t frames_dropped_error = 0;         // a publish failed mid-frame (the rest was not sent)
  int64_t disconnects = 0;
  int64_t reconnects = 0;
  std::string last_error;
};

class NatsPublisher {
 public:
  // Plans the stream against the pipeline (InvalidArgument / FailedPrecondition as
  // StreamFrames refuses), connects (Unauthenticated for refused credentials; a server not up
  // yet is waited for in the background), creates or updates the JetStream stream when
  // connected, subscribes to `pipeline` (not owned; it must outlive the publisher) and starts
  // publishing.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<NatsPublisher>> Start(
      Pipeline* pipeline, NatsPublishOptions options);
  ~NatsPublisher();  // Stop()

  // Ends the thread, waits up to a second for outstanding acknowledgements, unsubscribes.
  void Stop();
  NatsPublishStats Stats() const;

 private:
  NatsPublisher() = default;
  static void OnAck(jsCtx* js, natsMsg* msg, jsPubAck* ack, jsPubAckErr* error, void* closure);
  void Run();
  absl::Status EnsureStream();
  // Publishes the messages of one frame; false when one failed.
  bool PublishFrame(v1::Frame frame);

  Pipeline* pipeline_ = nullptr;
  NatsPublishOptions options_;
  StreamPlan plan_;
  std::string key_;
  std::unique_ptr<wire::NatsConnection> connection_;
  std::shared_ptr<Subscription> subscription_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  int64_t stream_epoch_ = -1;  // reconnects() when the stream was last made sure of

  std::atomic<uint64_t> frames_published_{0};
  std::atomic<uint64_t> messages_published_{0};
  std::atomic<uint64_t> messages_acknowledged_{0};
  std::atomic<uint64_t> messages_failed_{0};
  std::atomic<uint64_t> dropped_disconnected_{0};
  std::atomic<uint64_t> dropped_behind_{0};
  std::atomic<uint64_t> dropped_error_{0};
  mutable absl::Mutex mu_;
  std::string last_error_ ABSL_GUARDED_BY(mu_);
};

}  // namespace transient::service

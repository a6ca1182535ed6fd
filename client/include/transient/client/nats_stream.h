// A camera's frames from NATS JetStream (README, "Many cameras, many machines"): the messages
// transientd's publisher (`--publish`) put on `transient.<camera>.<product>`, joined and decoded
// into the same StreamFrame as the gRPC stream's, so that an application switches transport by
// opening this instead of Client::StreamFrames. Live, or replayed from the stream's start, a
// stream sequence or a time, then live, in order, without gaps or repeats (an ordered
// consumer). Links libnats (target transient_client_nats).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "transient/client/frame_stream.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/nats.h"

namespace transient::client {

struct NatsStreamOptions {
  wire::NatsConnectOptions connect;
  std::string camera = "camera";
  v1::Product product = v1::MOMENT_STATE;
  enum class Start {
    kNew,       // frames published from now on
    kAll,       // every frame the stream still keeps, then live
    kSequence,  // from the stream's message `start_sequence`, then live
    kTime,      // from frames stored at `start_time` or later, then live
  };
  Start start = Start::kNew;
  uint64_t start_sequence = 1;
  absl::Time start_time = absl::UnixEpoch();
  // As StreamOptions: a flag that ends a blocked Next, and a time at which the stream ends.
  const std::atomic<bool>* cancel = nullptr;
  absl::Time deadline = absl::InfiniteFuture();
};

// Where a consumer starts, as the command line says it, into *options: "new", "all", "seq:N"
// (N >= 1), "ago:SECONDS" (frames stored that long ago or later: the last minute again is
// ago:60) or "time:RFC3339" (2026-12-03T10:00:00Z). InvalidArgument naming `option` otherwise.
absl::Status ParseNatsStart(const std::string& option, const std::string& text,
                            NatsStreamOptions* options);

class NatsFrameStream {
 public:
  // Connects and subscribes. InvalidArgument for a bad camera name or option, Unavailable when
  // no server answers, Unauthenticated for refused credentials, NotFound when the camera has
  // no stream on the server (no publisher ever ran).
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<NatsFrameStream>> Open(
      const NatsStreamOptions& options);
  ~NatsFrameStream();
  NatsFrameStream(const NatsFrameStream&) = delete;
  NatsFrameStream& operator=(const NatsFrameStream&) = delete;

  // Blocks until the next frame and fills *frame (kImages, or kCorrupt for a frame that does not
  // decode; `missed` counts frames the publisher dropped and frames whose parts this consumer
  // did not all receive); false once cancelled or past the deadline (Finish says which). While
  // the server is away it waits: the subscription resumes where it was when it returns.
  bool Next(StreamFrame* frame);
  void Cancel() { cancelled_.store(true); }
  // OK after the deadline, Cancelled after Cancel or the cancel flag.
  absl::Status Finish();

  const StreamCounts& counts() const { return counts_; }
  const absl::Status& last_corruption() const { return last_corruption_; }
  // The JetStream stream sequence of the last message of the last frame returned.
  uint64_t stream_sequence() const { return stream_sequence_; }
  // The base frequency of the last frame's camera (its Transient-Base-Frequency-Hz header),
  // 0 before the first or without the header.
  double base_frequency_hz() const { return base_frequency_hz_; }
  // Frames dropped because some of their parts did not arrive.
  int64_t incomplete() const { return assembler_.abandoned(); }

 private:
  NatsFrameStream() = default;

  NatsStreamOptions options_;
  std::unique_ptr<wire::NatsConnection> connection_;
  natsSubscription* subscription_ = nullptr;
  wire::FrameAssembler assembler_;
  int64_t incomplete_reported_ = 0;
  std::atomic<bool> cancelled_{false};
  bool past_deadline_ = false;
  StreamCounts counts_;
  absl::Status last_corruption_;
  uint64_t stream_sequence_ = 0;
  double base_frequency_hz_ = 0.0;
};

}  // namespace transient::client

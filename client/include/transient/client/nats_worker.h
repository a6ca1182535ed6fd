// A reconstruction worker on NATS JetStream (`transient worker`; README, "Many cameras, many
// machines"): it pulls a camera's MOMENT_STATE frames from a durable consumer that every worker
// of the same group shares, computes the heavy products from them (MESE slices and cumulative
// at chosen times of flight, the Pisarenko direct/indirect split), publishes those to
// `transient.<camera>.<product>` and only then acknowledges the frame. So several machines
// share one camera's load: each frame goes to one worker, and a frame whose worker dies before
// acknowledging it is delivered again, to another, after `ack_wait`.
//
// A worker needs a frame in one message: the publisher's frames must fit the server's
// max_payload (FLOAT16 and ZSTD shrink them); a frame in parts is refused (terminated, never
// redelivered) and counted.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "transient/client/decoded_image.h"
#include "transient/reconstruct/reconstructor.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/nats.h"

namespace transient::client {

struct NatsWorkerOptions {
  wire::NatsConnectOptions connect;
  std::string camera = "camera";
  std::string group = "workers";  // the durable consumer the workers share
  // SLICES, CUMULATIVE and/or DIRECT_INDIRECT.
  std::vector<v1::Product> products = {v1::SLICES};
  int bins = 64;  // slices uniform over one modulation period
  v1::Encoding encoding = v1::FLOAT32;
  v1::Compression compression = v1::COMPRESSION_NONE;
  absl::Duration ack_wait = absl::Seconds(10);  // a frame unacknowledged this long goes again
};

struct NatsWorkerCounts {
  int64_t frames_done = 0;         // products published, frame acknowledged
  int64_t frames_redelivered = 0;  // of those, frames another worker had taken before
  int64_t frames_refused = 0;      // in parts, or not a MOMENT_STATE frame: terminated
  int64_t publish_failures = 0;    // products not stored: the frame is left to be redelivered
};

// The solved state of a MOMENT_STATE frame's images (c_0..c_m, q_0..q_m, as float32 on the
// wire): pixels whose q_0 is NaN are invalid (kFlagInvalidInput). DataLoss naming what is
// missing when the images are not a whole state of one geometry.
[[nodiscard]] absl::StatusOr<SolvedImage> SolvedFromMomentState(
    const std::vector<DecodedImage>& images);

class NatsWorker {
 public:
  // Connects and creates (or joins) the group's durable pull consumer of
  // transient.<camera>.moment_state. InvalidArgument for bad options, Unavailable /
  // Unauthenticated / NotFound as NatsFrameStream::Open.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<NatsWorker>> Open(
      const NatsWorkerOptions& options);
  ~NatsWorker();
  NatsWorker(const NatsWorker&) = delete;
  NatsWorker& operator=(const NatsWorker&) = delete;

  // Takes the next frame (waiting up to `wait`), computes and publishes its products, then
  // acknowledges it. false when no frame came in `wait`; an error when publishing failed (the
  // frame is not acknowledged: it will come again).
  absl::StatusOr<bool> ProcessOne(absl::Duration wait);
  const NatsWorkerCounts& counts() const { return counts_; }
  // Why the last refused frame was refused; OK when none was.
  const absl::Status& last_refusal() const { return last_refusal_; }
  // The frame sequences this worker completed, in order.
  const std::vector<uint64_t>& done() const { return done_; }

 private:
  NatsWorker() = default;
  absl::Status Publish(v1::Frame frame, double base_frequency_hz);

  NatsWorkerOptions options_;
  std::unique_ptr<wire::NatsConnection> connection_;
  natsSubscription* subscription_ = nullptr;
  NatsWorkerCounts counts_;
  absl::Status last_refusal_;
  std::vector<uint64_t> done_;
};

}  // namespace transient::client

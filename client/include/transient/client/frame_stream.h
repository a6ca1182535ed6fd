// A subscription to transientd's frames (StreamFrames), read one frame at a time with a
// blocking call and decoded: images with their units, state announcements, missed frames and
// latency. Corrupt frames are dropped and counted, never returned as images.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "transient/client/decoded_image.h"
#include "transient/v1/transient.grpc.pb.h"
#include "transient/v1/transient.pb.h"

namespace transient::client {

class StreamWatcher;

struct StreamOptions {
  // When *cancel turns true (a signal handler may set it), a blocked Next returns false and
  // Finish says Cancelled. May be null.
  const std::atomic<bool>* cancel = nullptr;
  // When it passes, the stream ends as if the caller had finished it: Next returns false and
  // Finish is OK. For "receive for S seconds".
  absl::Time deadline = absl::InfiniteFuture();
};

// One message of the stream.
struct StreamFrame {
  enum class Kind {
    kImages,         // the products asked for, decoded
    kAnnouncement,   // no images: the source's state changed (`state`)
    kCorrupt,        // an image did not decode: the frame is dropped, `corruption` says why
  };
  Kind kind = Kind::kImages;
  uint64_t sequence = 0;        // Frame.sequence (0 for announcements)
  double capture_time_s = 0.0;  // source timestamp of the cycle's first raw frame
  v1::SourceState state = v1::SOURCE_STATE_UNSPECIFIED;
  uint64_t missed = 0;  // frames the daemon dropped for this subscriber since the previous one
  // Seconds from the end of the frame's capture to its arrival here: the daemon's own
  // Frame.latency_s plus (arrival - Frame.publish_time). NaN when the frame has no publish time.
  double latency_s = std::numeric_limits<double>::quiet_NaN();
  absl::Time arrival;
  std::vector<DecodedImage> images;  // kImages only
  absl::Status corruption;           // kCorrupt only: DataLoss naming the image and the frame
};

// What a stream received so far.
struct StreamCounts {
  int64_t frames = 0;         // kImages frames
  int64_t announcements = 0;  // kAnnouncement frames
  int64_t corrupt = 0;        // kCorrupt frames (dropped)
  uint64_t missed = 0;        // sum of StreamFrame::missed
};

// Decodes one message of a frame stream (transientd's gRPC stream or its NATS subjects) that
// arrived at `arrival` into *frame, and counts it in *counts; a corrupt frame's reason also goes
// to *last_corruption.
void DecodeStreamMessage(const v1::Frame& wire, absl::Time arrival, StreamFrame* frame,
                         StreamCounts* counts, absl::Status* last_corruption);

// Made by Client::StreamFrames. Next and Finish are for one thread; Cancel for any thread,
// while the stream exists.
class FrameStream {
 public:
  FrameStream(const FrameStream&) = delete;
  FrameStream& operator=(const FrameStream&) = delete;
  // Finishes the stream if the caller did not.
  ~FrameStream();

  // Blocks until the next message and fills *frame; false when the stream has ended (the
  // daemon ended it, Cancel, StreamOptions::cancel or deadline): Finish says how.
  bool Next(StreamFrame* frame);

  // Ends the stream from any thread: a blocked Next returns false, Finish says Cancelled.
  void Cancel();

  // Ends the stream (cancelling it if it still runs) and says how it ended: OK when the daemon
  // ended it cleanly, when the deadline passed, or when the caller finished it before its end;
  // Cancelled after Cancel or StreamOptions::cancel; otherwise the daemon's status as it sent
  // it (wire::FromGrpcStatus: a refused request is its InvalidArgument naming the field, an
  // ended replay OutOfRange). The same status on later calls.
  absl::Status Finish();

  const StreamCounts& counts() const { return counts_; }
  // The corruption of the last kCorrupt frame; OK when there was none.
  const absl::Status& last_corruption() const { return last_corruption_; }
  const std::string& address() const { return address_; }

 private:
  friend class Client;
  FrameStream(std::shared_ptr<grpc::Channel> channel, std::string address,
              const v1::StreamRequest& request, const StreamOptions& options);

  const std::string address_;
  std::unique_ptr<v1::Transient::Stub> stub_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader_;
  std::unique_ptr<StreamWatcher> watcher_;  // only with a cancel flag or a deadline
  std::atomic<bool> cancelled_{false};      // Cancel was called
  bool ended_ = false;                      // Next saw the end
  bool finished_ = false;
  absl::Status status_;  // Finish's, once finished_
  StreamCounts counts_;
  absl::Status last_corruption_;
};

}  // namespace transient::client

// A subscriber's stream of the daemon's frames, planned and encoded: a StreamRequest checked
// and resolved against the sensor and the schedule (StreamPlan), and each published frame as
// the v1::Frame that plan sends. One home for what a gRPC stream (server.cc) and the NATS
// publisher (nats_publisher.h) send, so that both carry the same bytes.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "transient/service/pipeline.h"
#include "transient/service/subscription.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/image_codec.h"
#include "transient/wire/product_encoder.h"

namespace transient::service {

inline constexpr int kDefaultSlices = 64;
inline constexpr int kDefaultQueueFrames = 4;
inline constexpr int kMaxQueueFrames = 64;
inline constexpr int64_t kMaxQueueBytes = int64_t{256} << 20;

// A subscriber's request, checked and resolved against the sensor.
struct StreamPlan {
  ProductRequest request;        // what the pipeline computes for it
  wire::ProductEncoding images;  // how its frames are encoded (products in the order asked)
  absl::Duration min_interval = absl::ZeroDuration();
  int queue_frames = kDefaultQueueFrames;
};

// Checks `request` against the pipeline's sensor and schedule: InvalidArgument naming the
// field, FailedPrecondition for a product the schedule cannot serve.
absl::StatusOr<StreamPlan> PlanStream(const v1::StreamRequest& request, const Pipeline& pipeline);

// FailedPrecondition for a product the schedule cannot serve, naming what is missing; OK
// otherwise (GetInfo lists the products this accepts).
absl::Status CheckScheduleServes(std::span<const v1::Product> products,
                                 bool moment_depth_of_returns, const ScheduleOptions& schedule);

// A stream's message for one published frame: its own fields (sequence, times, ROI, missed)
// and the images of the frame's encoding for its plan, which every stream of that plan shares:
// lent to the message, not copied (5 MB a frame at 163x120 with 64 slices, 78 MB at 640x480,
// for every subscriber). `frame()` is for reading and serializing only: protobuf's const
// methods may run on the shared images from several streams at once. The images go back
// before the message is destroyed, and `images` keeps them alive until then.
class StreamMessage {
 public:
  StreamMessage(v1::Frame fields, std::shared_ptr<const v1::Frame> images);
  ~StreamMessage();
  StreamMessage(const StreamMessage&) = delete;
  StreamMessage& operator=(const StreamMessage&) = delete;

  const v1::Frame& frame() const { return frame_; }

 private:
  std::shared_ptr<const v1::Frame> images_;
  v1::Frame frame_;
};

// The message of a published frame with images (not an announcement) for a stream of `plan`
// (`key` = wire::EncodingKey(plan.images)): its images encoded once per plan and shared through
// `published.encoded`, its sequence, times, ROI and `missed`. Null when the frame was
// published before the plan's products were computed.
absl::StatusOr<std::unique_ptr<StreamMessage>> MessageForStream(const StreamPlan& plan,
                                                                const std::string& key,
                                                                const PublishedFrame& published,
                                                                uint64_t missed);

// The same message as a v1::Frame of its own, the images copied: for a sender that takes the
// frame apart (the NATS publisher cuts it into messages). nullopt as MessageForStream's null.
absl::StatusOr<std::optional<v1::Frame>> FrameForStream(const StreamPlan& plan,
                                                        const std::string& key,
                                                        const PublishedFrame& published,
                                                        uint64_t missed);

v1::SourceState ToProto(SourceState state);
google::protobuf::Timestamp ToTimestamp(absl::Time t);

}  // namespace transient::service

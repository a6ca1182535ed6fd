// A subscriber of the daemon's frames (DESIGN.md, "Threads"): what it asked to be computed and
// its own bounded queue of published frames. A slow subscriber loses its oldest frames and is
// told how many; it never makes the pipeline or another subscriber wait.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "transient/service/products.h"

namespace transient::service {

enum class SourceState { kStreaming, kReconnecting, kEnded };
const char* SourceStateName(SourceState state);  // "streaming", "reconnecting", "ended"

// A frame's images as encoded for the streams of one plan (products, region, encoding,
// compression), shared by the subscribers with that plan: a frame is encoded once per plan,
// however many subscribers take it. Kept while the frame is the newest published (the
// pipeline clears the previous frame's when it publishes the next), so a frame waiting in a
// slow subscriber's queue holds no encodings; a stream that comes to it later encodes its own.
// Thread-safe.
class EncodedImages {
 public:
  // The images stored under `key`, or null.
  std::shared_ptr<const v1::Frame> Find(const std::string& key) const;
  // Stores `images` under `key` unless another stream's are there, and returns what is stored;
  // after Clear, stores nothing and returns `images`.
  std::shared_ptr<const v1::Frame> Insert(const std::string& key,
                                          std::shared_ptr<const v1::Frame> images);
  // Drops every encoding (streams that hold one keep it) and stores no more.
  void Clear();
  // How many Find calls found images.
  int64_t hits() const;

 private:
  mutable absl::Mutex mu_;
  std::vector<std::pair<std::string, std::shared_ptr<const v1::Frame>>> images_
      ABSL_GUARDED_BY(mu_);  // one entry per plan: a list beats a map
  mutable int64_t hits_ ABSL_GUARDED_BY(mu_) = 0;
  bool cleared_ ABSL_GUARDED_BY(mu_) = false;
};

// One published transient frame: immutable once shared, but for the cache of its encodings.
struct PublishedFrame {
  uint64_t sequence = 0;
  double capture_time_s = 0.0;  // source timestamp of the cycle's first raw frame
  absl::Time arrival;           // when the cycle's last raw frame came from the source
  absl::Time publish;
  SourceState state = SourceState::kStreaming;
  bool announcement = false;    // a state change without images
  std::shared_ptr<const FrameProducts> products;  // null for an announcement
  mutable EncodedImages encoded;                   // filled by the subscribers' streams
};

// What a subscriber asked the pipeline to compute (encoding and ROI are its own business).
struct ProductRequest {
  ProductSet products;
  std::vector<double> slice_phases;  // radians, for SLICES and CUMULATIVE
  MomentDepthSpec moment_depth;      // for MOMENT_DEPTH
};

class Subscription {
 public:
  Subscription(uint64_t id, std::string peer, ProductRequest request, int queue_frames);

  // The subscriber's side. The next frame, waiting at most `timeout`; nullptr on timeout or
  // when closed. `missed` is the number of frames dropped from this queue since the previous
  // call.
  std::shared_ptr<const PublishedFrame> Next(absl::Duration timeout, uint64_t* missed);
  bool closed() const;
  const ProductRequest& request() const { return request_; }
  uint64_t id() const { return id_; }
  const std::string& peer() const { return peer_; }
  uint64_t frames_delivered() const;
  uint64_t frames_missed() const;

  // The pipeline's side. Frames beyond the queue's capacity drop oldest-first; announcements
  // only when the queue holds nothing else, so that the newest state always stays. After
  // Close(), Push does nothing and Next returns what is queued, then nullptr.
  void Push(std::shared_ptr<const PublishedFrame> frame);
  void Close();

 private:
  const uint64_t id_;
  const std::string peer_;
  const ProductRequest request_;
  const size_t capacity_;
  mutable absl::Mutex mu_;
  std::deque<std::shared_ptr<const PublishedFrame>> queue_ ABSL_GUARDED_BY(mu_);
  uint64_t missed_since_last_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t missed_total_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t delivered_ ABSL_GUARDED_BY(mu_) = 0;
  bool closed_ ABSL_GUARDED_BY(mu_) = false;
};

}  // namespace transient::service

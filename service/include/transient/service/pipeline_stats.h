// What the daemon counts (GetStats, the stats log line): every stage's counters, the latency
// of recent frames, the reconstruction rate, the subscribers and the recording.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "transient/drivers/capture_source.h"
#include "transient/service/products.h"
#include "transient/service/subscription.h"

namespace transient::service {

struct SubscriberSnapshot {
  uint64_t id = 0;
  std::string peer;
  uint64_t frames_sent = 0, frames_missed = 0;
  ProductSet products;
};

struct RecordingStatus {
  std::string path;
  bool active = false;
  uint64_t raw_frames = 0, flushed_frames = 0;
  std::string error;  // why the last recording stopped by itself
};

struct PipelineStats {
  uint64_t raw_frames_in = 0, raw_frames_dropped = 0, raw_frames_rejected = 0;
  uint64_t cycles_assembled = 0, cycles_dropped = 0, cycles_refused = 0;
  uint64_t frames_reconstructed = 0, frames_published = 0, source_reopens = 0;
  SourceState state = SourceState::kStreaming;
  // Over the last kLatencyWindow published frames, from the cycle's last raw frame to
  // publication (percentile.h, the statistic clients use); 0 before the first frame.
  double latency_p50_ms = 0, latency_p90_ms = 0, latency_p99_ms = 0, latency_max_ms = 0;
  double reconstruct_ms_mean = 0;
  double frames_per_second = 0;  // reconstructed, over the last kRateWindow
  std::vector<SubscriberSnapshot> subscribers;
  RecordingStatus recording;
  // The open source's own counters (CaptureSource::Counters: a camera's buffers, dropped
  // sequences by reason, restarts), since it was opened; the last ones while it is closed.
  std::vector<SourceCounter> source_counters;
};

// The timing part of PipelineStats: latencies, reconstruction time and rate. Not thread-safe:
// the pipeline holds its own lock around it.
class FrameTimings {
 public:
  static constexpr size_t kLatencyWindow = 1024;
  static constexpr absl::Duration kRateWindow = absl::Seconds(5);

  // A frame published `latency` after its cycle's last raw frame arrived.
  void AddPublished(absl::Duration latency);
  // A frame reconstructed in `took`, done at `done`.
  void AddReconstructed(absl::Duration took, absl::Time done);
  // Fills the latency, reconstruction time and rate fields of `stats` (frames_reconstructed
  // must be set).
  void Fill(PipelineStats* stats) const;

 private:
  std::deque<double> latencies_ms_;
  std::deque<absl::Time> reconstructed_;
  double reconstruct_ms_total_ = 0.0;
};

}  // namespace transient::service

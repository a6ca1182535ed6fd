// Latency percentiles, reconstruction time and rate of the daemon's frames.
#include "transient/service/pipeline_stats.h"

#include <span>

#include "transient/reconstruct/percentile.h"

namespace transient::service {

void FrameTimings::AddPublished(absl::Duration latency) {
  latencies_ms_.push_back(absl::ToDoubleMilliseconds(latency));
  if (latencies_ms_.size() > kLatencyWindow) latencies_ms_.pop_front();
}

void FrameTimings::AddReconstructed(absl::Duration took, absl::Time done) {
  reconstruct_ms_total_ += absl::ToDoubleMilliseconds(took);
  reconstructed_.push_back(done);
  while (reconstructed_.size() > 1 && reconstructed_.front() < done - kRateWindow) {
    reconstructed_.pop_front();
  }
}

void FrameTimings::Fill(PipelineStats* s) const {
  if (!latencies_ms_.empty()) {
    std::vector<double> latencies(latencies_ms_.begin(), latencies_ms_.end());
    s->latency_p50_ms = Percentile(std::span<double>(latencies), 50.0);
    s->latency_p90_ms = Percentile(std::span<double>(latencies), 90.0);
    s->latency_p99_ms = Percentile(std::span<double>(latencies), 99.0);
    s->latency_max_ms = Percentile(std::span<double>(latencies), 100.0);
  }
  if (s->frames_reconstructed > 0) {
    s->reconstruct_ms_mean = reconstruct_ms_total_ / static_cast<double>(s->frames_reconstructed);
  }
  if (reconstructed_.size() >= 2) {
    s->frames_per_second = static_cast<double>(reconstructed_.size() - 1) /
                           absl::ToDoubleSeconds(reconstructed_.back() - reconstructed_.front());
  }
}

}  // namespace transient::service

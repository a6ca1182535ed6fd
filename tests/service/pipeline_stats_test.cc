// The daemon's timing statistics: the client's percentile over the latency window, the mean
// reconstruction time, and the rate over the last seconds.
#include "transient/service/pipeline_stats.h"

#include <gtest/gtest.h>

namespace transient::service {
namespace {

TEST(FrameTimings, LatencyPercentilesAreThoseOfTheLastWindowOfFrames) {
  FrameTimings timings;
  // 2000 frames; only the last 1024 (latencies 976..1999 ms) count.
  for (int i = 0; i < 2000; ++i) timings.AddPublished(absl::Milliseconds(i));
  PipelineStats stats;
  timings.Fill(&stats);
  EXPECT_DOUBLE_EQ(stats.latency_max_ms, 1999.0);
  EXPECT_DOUBLE_EQ(stats.latency_p50_ms, 976.0 + 0.5 * 1023.0);
  EXPECT_NEAR(stats.latency_p99_ms, 976.0 + 0.99 * 1023.0, 1e-9);
}

TEST(FrameTimings, NothingPublishedLeavesZerosNotNan) {
  PipelineStats stats;
  FrameTimings().Fill(&stats);
  EXPECT_EQ(stats.latency_p50_ms, 0.0);
  EXPECT_EQ(stats.latency_max_ms, 0.0);
  EXPECT_EQ(stats.frames_per_second, 0.0);
  EXPECT_EQ(stats.reconstruct_ms_mean, 0.0);
}

TEST(FrameTimings, RateIsOverTheLastFiveSecondsAndMeanOverAllFrames) {
  FrameTimings timings;
  const absl::Time start = absl::UnixEpoch();
  // 10 frames a second for 20 s, each taking 30 ms.
  for (int i = 0; i <= 200; ++i) {
    timings.AddReconstructed(absl::Milliseconds(30), start + absl::Milliseconds(100 * i));
  }
  PipelineStats stats;
  stats.frames_reconstructed = 201;
  timings.Fill(&stats);
  EXPECT_NEAR(stats.frames_per_second, 10.0, 1e-9);
  EXPECT_NEAR(stats.reconstruct_ms_mean, 30.0, 1e-9);
}

}  // namespace
}  // namespace transient::service

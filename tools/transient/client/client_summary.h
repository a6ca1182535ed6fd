// What `transient client` measured of a stream: rate, latency, state changes, the last frame's
// slices and moment-depth map, the files written; as summary.json and as terminal lines.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace transient::tools {

struct ClientLatency {
  // Milliseconds from the end of the frame's capture to its arrival here: the daemon's own
  // Frame.latency_s plus (arrival wall time - Frame.publish_time). NaN when no frame had a
  // publish time.
  double p50_ms = 0.0, p90_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
};

struct ClientStateChange {
  int64_t after_frames = 0;  // frames with images received before the announcement
  std::string state = {};    // STREAMING, RECONNECTING, ENDED
};

struct ClientSummary {
  std::string address = {};
  std::string source_uri = {};
  std::string version = {};  // the daemon's
  int camera_width = 0, camera_height = 0;
  int64_t frames = 0;               // frames with images, decoded
  int64_t corrupt_frames = 0;       // frames with an image DecodeImage refused (dropped)
  int64_t state_announcements = 0;  // frames without images
  std::vector<ClientStateChange> state_changes = {};
  double seconds = 0.0;  // from opening the stream to the last frame
  double rate_hz = 0.0;  // (frames - 1) / (last arrival - first arrival); 0 below two frames
  ClientLatency latency = {};
  uint64_t frames_missed = 0;  // sum of Frame.missed: frames the daemon dropped for us
  // The source's counters (GetStats' source_counters: a camera's buffers, the sequences it
  // dropped by reason, restarts) after the stream, by name; none known when GetStats failed.
  std::optional<std::vector<std::pair<std::string, int64_t>>> source_counters = std::nullopt;
  std::vector<double> slice_time_of_flight_ns = {};  // of the last frame's slices
  float slice_scale = 0.0f;       // colour scale of the slice images (value at full colour)
  float cumulative_scale = 0.0f;  // of the cumulative images
  // MOMENT_DEPTH of the last frame: the map's parameters as the daemon sent them, and the
  // virtual plane's occlusion computed from it.
  struct MomentDepth {
    int bits = 0;
    double near_m = 0.0, far_m = 0.0, sigma_px = 0.0;
    bool from_returns = false;
    int64_t empty_pixels = 0;
    double virtual_plane_m = 0.0;
    double occluded_share = 0.0;  // mean occlusion fraction of the plane over the image
  };
  std::optional<MomentDepth> moment_depth = std::nullopt;
  std::vector<std::string> files = {};  // written, relative to output_dir, summary.json last
  std::string output_dir = {};
  bool interrupted = false;
  std::string stream_error = {};  // how the stream ended when it failed
};

// The summary as JSON (the content of summary.json) and as a few lines for a terminal.
std::string ClientSummaryJson(const ClientSummary& summary);
std::string FormatClientSummary(const ClientSummary& summary);

}  // namespace transient::tools

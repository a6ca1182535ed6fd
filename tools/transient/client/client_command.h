// `transient client`: subscribes to a running transientd over gRPC, receives frames, measures
// rate and latency, and writes the products of the last frame as images plus a JSON summary.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/capture_commands.h"

namespace transient::tools {

// A region of interest in sensor pixels; width = height = 0 is the whole sensor.
struct ClientRoi {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
};

// "X,Y,W,H" (four non-negative integers). InvalidArgument naming --roi otherwise.
[[nodiscard]] absl::StatusOr<ClientRoi> ParseRoi(const std::string& text);

// `transient client [--connect ADDR] --products range,slices --frames N --out DIR`.
struct ClientArgs {
  std::string connect = "127.0.0.1:50051";  // gRPC target: host:port, or unix:PATH
  std::vector<std::string> products = {"range", "slices"};  // wire::ProductNames()
  int64_t frames = 30;   // frames with images to receive; 0 = --seconds decides
  double seconds = 0.0;  // wall-clock seconds to receive for; 0 = --frames decides
  std::string output_dir = {};  // created if missing
  ClientRoi roi = {};
  int bins = 64;                    // slices uniform over one period, 1..wire::kMaxSlices
  std::string encoding = "float32";  // wire::EncodingChoices(): float32 | float16 | mm
  bool zstd = false;                 // ask for zstd-compressed images
  double max_rate_hz = 0.0;          // at most this many frames a second; 0 = every frame
  double connect_timeout_s = 5.0;    // how long to wait for the daemon, > 0

  // moment_depth (MOMENT_DEPTH): the map asked for (v1::MomentDepthRequest), and the depth of
  // a virtual plane, facing the camera, whose occlusion by the real scene the client computes
  // from the map, as a renderer would (MomentDepthMap::Occlusion).
  double moment_near_m = 0.0;  // near = far = 0: the daemon's default [0, unambiguous range]
  double moment_far_m = 0.0;
  std::optional<double> moment_sigma_px = std::nullopt;  // unset: the daemon's default, 1 px
  int moment_bits = 64;                                  // 64 or 128
  bool moment_from_returns = false;
  std::optional<double> virtual_plane_m = std::nullopt;  // default: middle of near..far

  // Exactly one of frames > 0 and seconds > 0; known, non-empty products; the encoding fits
  // them; bins 1..1024; a non-negative finite rate; an output directory; moment options: near
  // >= 0 and far > near (or both 0), sigma finite >= 0, bits 64 or 128, a finite virtual plane
  // > 0 m. The message names the option, the value and the rule.
  absl::Status Validate() const;
};

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

// Connects to transientd at args.connect with the client library (client::Client: Unavailable
// "cannot reach transientd at ADDR within 5 s" when it does not answer in connect_timeout_s),
// calls GetInfo, then StreamFrames, and receives frames until args.frames frames with images
// arrived or args.seconds passed. Each image of each frame is decoded (client::DecodeFrame); a
// frame with an undecodable image is counted in corrupt_frames and skipped. Then writes into output_dir the products of the last good frame
// (images of products that were not asked for are ignored):
//   depth.png (16-bit mm, 0 = invalid)          DEPTH
//   range.tiff (float m, NaN = none)            RANGE; also range_mm.png when DEPTH was not asked
//   amplitude.tiff, c0.tiff                     AMPLITUDE, C0
//   flags.png (8-bit, PixelFlag bits)           FLAGS
//   slices/slice_000.png ...                    SLICES, colour-mapped (inferno), one scale for all
//   cumulative/slice_000.png ...                CUMULATIVE, likewise
//   moment_state/, direct_indirect/ (float TIFF per plane, or <product>.tiff for one plane)
//   moment_depth/b1.tiff .. b4.tiff             MOMENT_DEPTH: the decoded moments (b_0 = 1)
//   moment_depth/occlusion_plane.png            MOMENT_DEPTH: 8-bit, 255 = the virtual plane
//                                                 at virtual_plane_m is hidden by the scene
//   summary.json                                always, even after an error
// The colour scale of a series is the 99.5th percentile of its finite values (1 when none is
// positive), so that the series reads as a video of the light sweeping through the scene.
// A stream that ends with an error returns the daemon's status (prefixed) after the
// files are written; one that the daemon ends cleanly is a summary. On hooks.cancel the files of
// what was received are written and Cancelled is returned. Progress: frames received of
// args.frames (total 0 with --seconds).
[[nodiscard]] absl::StatusOr<ClientSummary> RunClient(const ClientArgs& args,
                                                      const CommandHooks& hooks = {});

// The summary as JSON (the content of summary.json) and as a few lines for a terminal.
std::string ClientSummaryJson(const ClientSummary& summary);
std::string FormatClientSummary(const ClientSummary& summary);

}  // namespace transient::tools

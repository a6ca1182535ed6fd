// `transient client`: subscribes to a running transientd over gRPC, receives frames, measures
// rate and latency, and writes the products of the last frame as images plus a JSON summary.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/client/client_summary.h"
#include "tools/transient/common/command_hooks.h"
#include "transient/client/client.h"
#include "transient/wire/address.h"
#include "transient/wire/nats.h"

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
  std::string connect = wire::kDefaultAddress;  // gRPC target: host:port, or unix:PATH
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
  client::ChannelSecurity security = {};  // TLS, client certificate, token (files)

  // --nats: receive from NATS JetStream instead of gRPC (README, "Many cameras, many
  // machines"): the frames transientd --publish put on transient.<nats_camera>.<product>, one
  // product. nats_start: "new" (frames from now on), "all" (every frame the stream keeps, then
  // live), "seq:N" (from the stream's message N, then live), "ago:SECONDS" or "time:RFC3339"
  // (client::ParseNatsStart).
  wire::NatsConnectOptions nats = {};  // nats.servers empty = gRPC
  std::string nats_camera = "camera";
  std::string nats_start = "new";

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

}  // namespace transient::tools

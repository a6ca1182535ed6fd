// `transient view INPUT --out DIR`: the pictures of thesis §8.5 from a reconstruction file (or a
// moment or capture file, reconstructed first into a temporary file, or frames received from a
// running transientd, INPUT = daemon:ADDR): transient slices and their MP4 video, cumulative
// frames, streak images, range, amplitude, flags, direct and indirect light, point clouds (PLY)
// and per-pixel plots; and the moment-depth pictures of thesis ch. 4 (moment_pictures.h). The command runs in-process; main.cc only maps its arguments and its
// status to the command line.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"
#include "tools/transient/common/frame_slice.h"
#include "tools/transient/view/moment_pictures.h"
#include "tools/transient/view/point_cloud.h"
#include "tools/transient/view/view_pictures.h"
#include "transient/client/client.h"

namespace transient::tools {

struct PixelPosition {
  int x = 0;
  int y = 0;
};

// Parses "X,Y" (--pixel). InvalidArgument naming the text otherwise.
[[nodiscard]] absl::StatusOr<PixelPosition> ParsePixelPosition(const std::string& text);
[[nodiscard]] absl::StatusOr<PlyFormat> ParsePlyFormat(const std::string& text);

// The quantile of the automatic colour scales: density, cumulative, c_0, direct/indirect
// [0, q-quantile]; range [(1 - q)-quantile, q-quantile].
inline constexpr double kScaleQuantile = 0.995;
// At most this many values are sampled per scale (an even stride over everything drawn).
inline constexpr int64_t kMaxScaleSamples = int64_t{1} << 22;

struct ViewArgs {
  // A transient-reconstruction, -moments or -capture file, or "daemon:" and the gRPC address of
  // a running transientd (daemon:127.0.0.1:50051, daemon:unix:/run/transientd.sock).
  std::string input_path = {};
  std::string output_dir = {};  // created when missing

  // What to draw. When none of these is chosen, everything the input allows: all of them, the
  // streak image of the middle row, the plot of the centre pixel, the point cloud when
  // intrinsics are known.
  bool slices = false;      // frame_NNN/slices/slice_BBB.png: density at each bin drawn
  bool cumulative = false;  // frame_NNN/cumulative/slice_BBB.png
  bool video = false;       // light.mp4: the slices of every frame, one video frame each
  bool images = false;      // frame_NNN/{range, amplitude, flags, direct, indirect,
                            // range_pisarenko}.png
  bool point_cloud = false;               // frame_NNN/points.ply
  std::vector<int> streak_rows = {};      // frame_NNN/streak_yYYY.png
  std::vector<PixelPosition> pixels = {}; // frame_NNN/pixel_xXXX_yYYY.png
  // frame_NNN/moment_depth/*.png (and moment_plane.mp4 with moment.video): moment depth maps and
  // virtual objects tested against them. Needs the intrinsics (camera_path). Not part of
  // "everything": drawn only when moment.enabled.
  MomentPictureOptions moment = {};

  // Round-trip times of flight to draw slices, cumulative frames and video frames at, ns in
  // [0, 1/f); each is drawn at the nearest bin. Empty: every bin.
  std::vector<double> tau_ns = {};
  // Upper end of the density colour scale (sensor units/rad); default: the kScaleQuantile
  // quantile of the density over all bins and pixels of the frames drawn.
  std::optional<double> density_scale = std::nullopt;
  FrameSlice frames = {};  // of the input file; must stay ":" for a daemon input

  // Daemon input only: frames to receive (RANGE, C0, FLAGS, CUMULATIVE, DIRECT_INDIRECT and
  // SLICES of `bins` uniform bins, at most 1024), and how long to wait for the connection.
  int64_t daemon_frames = 4;
  double connect_timeout_s = 5.0;
  client::ChannelSecurity security = {};  // TLS, client certificate, token (files)

  std::string camera_path = {};  // capture file whose /camera intrinsics place the points
  PlyFormat ply_format = PlyFormat::kBinary;
  bool ply_colour = true;  // colour points by c_0
  double fps = 16.0;       // video frames per second

  // Moment and capture inputs: how they are reconstructed (transient reconstruct); daemon input:
  // the slices asked for.
  int bins = 64;
  std::optional<double> bounds_r = 0.5;  // /bounds for the per-pixel plot's band; none: off
  std::string calibration_path = {};     // capture input: default the embedded calibration

  // Checks every option on its own; the message names the option, its value and the rule.
  absl::Status Validate() const;
};

struct ViewSummary {
  std::string input_path = {};
  std::string output_dir = {};
  std::string input_kind = {};  // "reconstruction", "moments", "capture", "transientd"
  int64_t frames = 0;
  ImageGeometry geometry = {};
  int64_t png_files = 0;
  int64_t ply_files = 0;
  int64_t video_frames = 0;  // 0: no video
  std::optional<MomentSetup> moment = std::nullopt;  // the moment pictures' range and placement
  int64_t moment_video_frames = 0;                   // moment_plane.mp4; 0: none
  ViewScales scales = {};
  bool density_drawn = false;  // slices, video, streak images or pixel plots
  bool density_scale_given = false;
  std::vector<std::string> notes = {};  // pictures skipped and why
  double seconds = 0.0;
};

// "drew 2 frames of 163x120 px (reconstruction rec.h5): 268 PNG, 2 PLY, light.mp4 with 128
// video frames -> out/; density scale 0..0.41 sensor units/rad (99.5th percentile), 3.2 s"
// followed by the moment pictures' setup (FormatMomentSetup) and one line per note.
std::string FormatViewSummary(const ViewSummary& summary);

// Runs the command. Bad options, a bad input, a tau outside one period, a pixel or scanline
// outside the image, a picture the input cannot give, or moment pictures without intrinsics, with
// a blur wider than the image, an empty depth range or objects behind far fail before anything
// is written
// (InvalidArgument/NotFound/OutOfRange naming the file and the rule, exit code 2). A daemon
// input is received first (DaemonFrameSource::Receive): an unreachable daemon is Unavailable
// naming the address (exit code 1, as `transient client`), and nothing is written. Progress is
// reported per frame drawn; cancellation stops between frames (files already complete stay).
[[nodiscard]] absl::StatusOr<ViewSummary> RunView(const ViewArgs& args,
                                                  const CommandHooks& hooks = {});

}  // namespace transient::tools

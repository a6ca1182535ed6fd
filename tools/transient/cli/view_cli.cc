// `transient view`: its command line (options of ViewArgs).
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/security_options.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/view/daemon_frame_source.h"
#include "tools/transient/view/view_command.h"
#include "transient/wire/product_registry.h"

namespace transient::tools::cli {
namespace view_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

struct ViewCommandLine {
  ::transient::tools::ViewArgs args;
  std::vector<std::string> pixels;
  std::string ply_format = "binary";
  std::string frames;
  CLI::Option* frames_option = nullptr;
  double scale = 0.0;
  CLI::Option* scale_option = nullptr;
  double bounds_r = 0.5;
  bool no_bounds = false;
  bool no_colour = false;
  double near_m = 0.0;
  CLI::Option* near_option = nullptr;
  double far_m = 0.0;
  CLI::Option* far_option = nullptr;
};

CLI::App* AddViewCommand(CLI::App& app, ViewCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "view",
      "Draw the pictures of a reconstruction file (or of a moment or capture file, "
      "reconstructed first, or of frames received from a running transientd, INPUT = "
      "daemon:ADDR): transient slices and their video, cumulative frames, streak images, range, "
      "amplitude, flags, direct/indirect light, point clouds and per-pixel plots (thesis §8.5). "
      "Without a picture option, draws all of them.");
  command->footer(
      "Files written into --out DIR (NNN: frame index in the input, BBB: bin):\n"
      "  light.mp4                          H.264 video of the density slices of every frame\n"
      "  frame_NNN/slices/slice_BBB.png     MESE density at one time of flight\n"
      "  frame_NNN/cumulative/slice_BBB.png light arrived by that time of flight\n"
      "  frame_NNN/streak_yYYY.png          density of scanline Y: x across, tau down\n"
      "  frame_NNN/{range,amplitude,flags,direct,indirect,range_pisarenko}.png\n"
      "  frame_NNN/points.ply               range * ray of every pixel with a range (metres,\n"
      "                                     x right, y down, z forward), coloured by c0\n"
      "  frame_NNN/pixel_xXXX_yYYY.png      density, bounds band, Pisarenko returns, cumulative\n"
      "  frame_NNN/moment_depth/            --moment-depth (thesis ch. 4): for each --blur S,\n"
      "    map_unfiltered.png, map_sigma_S.png  the 64-bit moment map as colour (eq. 4.4)\n"
      "    plane_sigma_S.png, sphere_sigma_S.png  virtual objects occluded by the real scene\n"
      "    shadow_sigma_S.png               light at the camera: the scene's shadow on a backdrop\n"
      "    compare_sigma_S.png              hard test, VSM, Hamburger, Hausdorff 4MSM (S nearest 2)\n"
      "  moment_plane.mp4                   --moment-video: hard test vs 4MSM, every frame\n"
      "Moment defaults from the depth percentiles d_lo/d_hi/d_top (0.5/95/99.5th) of the frames\n"
      "drawn, m = 0.1 d_hi: near = 0.85 d_lo, far = 1.15 d_top (rounded outward to 0.1 m);\n"
      "plane from Z = d_hi - 2m (left) to d_hi + m (right); sphere of radius m at Z = d_hi + m/2\n"
      "on the centre ray; backdrop from (d_lo + d_hi)/2 - m to d_hi + m. The summary prints them.\n"
      "Colour scales are fixed for the whole run: density, cumulative, c0 and direct/indirect\n"
      "from 0 to their 99.5th percentile over every frame drawn (density: all bins, or --scale),\n"
      "range from its 0.5th to its 99.5th percentile; grey = no value.\n"
      "A daemon input (daemon:HOST:PORT or daemon:unix:PATH) receives --frames N frames (default\n"
      "4) of the whole sensor with --bins slices, then draws them as frame_000.. ; transientd\n"
      "sends no Pisarenko returns or bounds, so the per-pixel plots lack them. A stream that\n"
      "ends early (a replay's end) draws the frames received.\n"
      "Exit codes: 0 done, 1 failure outside the input (daemon unreachable), 2 bad options or\n"
      "input, 130 interrupted.");
  ::transient::tools::ViewArgs& args = line.args;
  command
      ->add_option("input", args.input_path,
                   "reconstruction (transient-reconstruction 1), moment or capture file, or "
                   "daemon:ADDR for a running transientd")
      ->required();
  command->add_option("--out", args.output_dir, "directory to write into (created if missing)")
      ->required();
  command->add_flag("--slices", args.slices, "density slices as PNG");
  command->add_flag("--cumulative", args.cumulative, "cumulative frames as PNG");
  command->add_flag("--video", args.video, "light.mp4: the density slices of every frame");
  command->add_flag("--images", args.images,
                    "range, amplitude (c0), flags, direct and indirect images");
  command->add_flag("--point-cloud", args.point_cloud,
                    "points.ply from range and the intrinsics of --camera");
  command->add_option("--streak", args.streak_rows, "streak image of scanline Y (repeatable)");
  command->add_option("--pixel", line.pixels, "plot of pixel X,Y (repeatable)");
  command
      ->add_option("--tau", args.tau_ns,
                   "times of flight in ns for slices, cumulative frames and video (nearest bin; "
                   "comma-separated or repeated; default: every bin)")
      ->delimiter(',');
  line.scale_option = command->add_option(
      "--scale", line.scale,
      "upper end of the density colour scale, sensor units/rad (default: 99.5th percentile)");
  line.frames_option = command->add_option(
      "--frames", line.frames,
      "frames A:B of the input file, a Python slice (default: all); daemon input: the number of "
      "frames to receive (default 4)");
  command->add_option("--camera", args.camera_path,
                      "capture file whose /camera intrinsics (fx, fy, cx, cy) place the points");
  command->add_option("--ply-format", line.ply_format, "ascii or binary")->capture_default_str();
  command->add_flag("--no-colour", line.no_colour, "points without colour");
  command->add_option("--fps", args.fps, "video frames per second")->capture_default_str();
  command
      ->add_option("--bins", args.bins,
                   absl::StrCat("moment or capture input: phases per period to reconstruct "
                                "(8..65536); daemon input: slices per period to receive (8..",
                                transient::wire::kMaxSlices, ")"))
      ->capture_default_str();
  command
      ->add_option("--bounds-r", line.bounds_r,
                   "moment or capture input: r of the bounds band (0 < R < 1)")
      ->capture_default_str();
  command->add_flag("--no-bounds", line.no_bounds,
                    "moment or capture input: do not compute the bounds");
  command->add_option("--calibration", args.calibration_path,
                      "capture input: calibration file (default: the embedded one)");
  AddSecurityOptions(command, &args.security);
  command
      ->add_option("--connect-timeout", args.connect_timeout_s,
                   "daemon input: seconds to wait for transientd to accept the connection")
      ->capture_default_str();

  ::transient::tools::MomentPictureOptions& moment = args.moment;
  CLI::Option_group* group = command->add_option_group(
      "Moment depth",
      "moment shadow mapping on the camera's depth (thesis ch. 4): virtual objects and a "
      "virtual backdrop tested against filtered 64-bit moment maps; needs --camera");
  group->add_flag("--moment-depth", moment.enabled,
                  "draw frame_NNN/moment_depth/ (range -> depth with the --camera intrinsics)");
  line.near_option = group->add_option(
      "--near", line.near_m, "depth mapped to -1, m (default: 0.85 x 0.5th depth percentile)");
  line.far_option = group->add_option(
      "--far", line.far_m, "depth mapped to +1, m (default: 1.15 x 99.5th depth percentile)");
  group
      ->add_option("--blur", moment.blur_px,
                   "Gaussian sigmas of the moment map, px (comma-separated; one set of pictures "
                   "each)")
      ->delimiter(',')
      ->capture_default_str();
  group->add_option("--upscale", moment.upscale, "output pixels per camera pixel (1..8)")
      ->capture_default_str();
  group
      ->add_option("--plane-depth", moment.plane_depth_m,
                   "LEFT,RIGHT: depth Z of the virtual plane's left and right edges, m")
      ->delimiter(',');
  group
      ->add_option("--sphere", moment.sphere_m,
                   "Z,R[,X,Y]: depth of the virtual sphere's centre and radius, m; X,Y: the pixel "
                   "its centre is seen at (default: the image centre)")
      ->delimiter(',');
  group
      ->add_option("--backdrop-depth", moment.backdrop_depth_m,
                   "LEFT,RIGHT: depth Z of the shadow backdrop's edges, m")
      ->delimiter(',');
  group->add_flag("--moment-video", moment.video,
                  "moment_plane.mp4: the plane, hard test vs Hamburger 4MSM, every frame");
  return command;
}

int RunViewCommand(ViewCommandLine& line) {
  ::transient::tools::ViewArgs& args = line.args;
  for (const std::string& text : line.pixels) {
    absl::StatusOr<::transient::tools::PixelPosition> pixel =
        ::transient::tools::ParsePixelPosition(text);
    if (!pixel.ok()) {
      std::cerr << ErrorLine(pixel.status()) << "\n";
      return kExitBadInput;
    }
    args.pixels.push_back(*pixel);
  }
  absl::StatusOr<::transient::tools::PlyFormat> ply = ::transient::tools::ParsePlyFormat(line.ply_format);
  if (!ply.ok()) {
    std::cerr << ErrorLine(ply.status()) << "\n";
    return kExitBadInput;
  }
  args.ply_format = *ply;
  args.ply_colour = !line.no_colour;
  if (line.scale_option->count() > 0) args.density_scale = line.scale;
  if (line.near_option->count() > 0) args.moment.near_m = line.near_m;
  if (line.far_option->count() > 0) args.moment.far_m = line.far_m;
  args.bounds_r = line.no_bounds ? std::nullopt : std::optional<double>(line.bounds_r);
  if (line.frames_option->count() > 0 && ::transient::tools::IsDaemonInput(args.input_path)) {
    if (!absl::SimpleAtoi(line.frames, &args.daemon_frames)) {
      std::cerr << ErrorLine(absl::InvalidArgumentError(absl::StrCat(
                       "--frames = '", line.frames,
                       "': a daemon input takes the number of frames to receive")))
                << "\n";
      return kExitBadInput;
    }
  } else if (line.frames_option->count() > 0) {
    absl::StatusOr<::transient::tools::FrameSlice> frames =
        ::transient::tools::ParseFrameSlice(line.frames);
    if (!frames.ok()) {
      std::cerr << ErrorLine(frames.status()) << "\n";
      return kExitBadInput;
    }
    args.frames = *frames;
  }
  if (absl::Status status = args.Validate(); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  return RunWithProgress<::transient::tools::ViewSummary>(
      [&](const ::transient::tools::CommandHooks& hooks) {
        return ::transient::tools::RunView(args, hooks);
      },
      ::transient::tools::FormatViewSummary);
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddViewCommand(app, line_); }
  int Run() override { return RunViewCommand(line_); }

 private:
  ViewCommandLine line_;
};

}  // namespace view_cli

std::unique_ptr<Subcommand> MakeViewCommand() {
  return std::make_unique<view_cli::Command>();
}

}  // namespace transient::tools::cli

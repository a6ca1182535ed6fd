// `transient client`: its command line (options of ClientArgs).
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <string>
#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/security_options.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/client/client_command.h"
#include "transient/wire/product_registry.h"

namespace transient::tools::cli {
namespace client_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

struct ClientCommandLine {
  ::transient::tools::ClientArgs args;
  std::string products = "range,slices";
  std::string roi;
  CLI::Option* frames_option = nullptr;
  CLI::Option* seconds_option = nullptr;
  double moment_sigma_px = 1.0;
  double virtual_plane_m = 0.0;
  CLI::Option* moment_sigma_option = nullptr;
  CLI::Option* virtual_plane_option = nullptr;
};

CLI::App* AddClientCommand(CLI::App& app, ClientCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "client",
      "Subscribe to a running transientd over gRPC, receive frames, and write the products of "
      "the last frame into a directory with a JSON summary of rate and latency.");
  command->footer(
      "Files written into --out DIR (from the last frame received):\n"
      "  depth.png          depth Z, 16-bit PNG in millimetres, 0 = invalid (REP 118)\n"
      "  range.tiff         radial range, 32-bit float TIFF in metres, NaN = no return\n"
      "  range_mm.png       range as 16-bit millimetres, when depth was not asked for\n"
      "  amplitude.tiff     |c_1|, c0.tiff: c_0, float TIFF in sensor units\n"
      "  flags.png          8-bit PixelFlag bits\n"
      "  slices/slice_NNN.png, cumulative/slice_NNN.png: colour-mapped (inferno) density and\n"
      "                     cumulative per time of flight, one colour scale per series (the\n"
      "                     99.5th percentile of its finite values), NaN grey\n"
      "  moment_state/, direct_indirect/: one float TIFF per plane\n"
      "  moment_depth/b1.tiff..b4.tiff: the moment depth map's moments of normalised depth\n"
      "  moment_depth/occlusion_plane.png: 8-bit occlusion of a virtual plane at --virtual-plane\n"
      "                     metres computed from the map (255 = hidden by the real scene)\n"
      "  summary.json       address, source, camera size, frames, seconds, rate_hz, latency_ms\n"
      "                     {p50, p90, p99, max} (daemon latency + network), frames_missed, state\n"
      "                     changes, slice_time_of_flight_ns, colour scales, moment_depth, files\n"
      "Exit codes: 0 done, 1 daemon unreachable or failed, 2 bad options, 130 interrupted (what\n"
      "arrived is written first).");
  ::transient::tools::ClientArgs& args = line.args;
  AddSecurityOptions(command, &args.security);
  command->add_option("--connect", args.connect, "address of transientd, host:port or unix:PATH")
      ->capture_default_str();
  command->add_option("--nats", args.nats.servers,
                      "receive from NATS JetStream instead, at these servers (nats://HOST:PORT, "
                      "comma-separated): what `transientd --publish` put on "
                      "transient.<camera>.<product>; one product");
  command->add_option("--nats-camera", args.nats_camera, "the camera's name on NATS")
      ->capture_default_str();
  command
      ->add_option("--nats-start", args.nats_start,
                   "new (frames from now on), all (every frame the stream keeps, then live), "
                   "seq:N (from the stream's message N), ago:SECONDS (the last seconds again) or "
                   "time:RFC3339")
      ->capture_default_str();
  AddNatsSecurityOptions(command, &args.nats);
  command
      ->add_option("--products", line.products,
                   absl::StrCat("comma-separated: ",
                                absl::StrJoin(transient::wire::ProductNames(), ", ")))
      ->capture_default_str();
  line.frames_option =
      command->add_option("--frames", args.frames, "frames with images to receive")
          ->capture_default_str();
  line.seconds_option = command->add_option(
      "--seconds", args.seconds, "receive for this many seconds instead of --frames");
  command->add_option("--out", args.output_dir, "directory to write into (created if missing)")
      ->required();
  command->add_option("--roi", line.roi,
                      "region of interest X,Y,W,H in sensor pixels (default: whole sensor)");
  command
      ->add_option("--bins", args.bins,
                   absl::StrCat("slices uniform over one modulation period, times of flight "
                                "n*T/N (1..",
                                transient::wire::kMaxSlices, ")"))
      ->capture_default_str();
  command
      ->add_option("--encoding", args.encoding,
                   "image encoding on the wire: float32, float16 or mm (16-bit millimetres, "
                   "range and depth only)")
      ->capture_default_str();
  command->add_flag("--zstd", args.zstd, "ask for zstd-compressed images");
  command
      ->add_option("--max-rate", args.max_rate_hz,
                   "at most this many frames per second, in Hz; 0 = every frame")
      ->capture_default_str();
  command
      ->add_option("--connect-timeout", args.connect_timeout_s,
                   "seconds to wait for the daemon to accept the connection")
      ->capture_default_str();
  command->add_option("--moment-near", args.moment_near_m,
                      "moment_depth: depth mapped to -1, metres (with --moment-far; both 0 = "
                      "the daemon's default, 0 to the unambiguous range)");
  command->add_option("--moment-far", args.moment_far_m, "moment_depth: depth mapped to +1, m");
  line.moment_sigma_option = command->add_option(
      "--moment-sigma", line.moment_sigma_px,
      "moment_depth: Gaussian blur of the moment map in pixels, 0 = none (default 1)");
  command->add_option("--moment-bits", args.moment_bits, "moment_depth: 64 or 128 bits per pixel")
      ->capture_default_str();
  command->add_flag("--moment-from-returns", args.moment_from_returns,
                    "moment_depth: moments of each pixel's Pisarenko returns (mixed pixels)");
  line.virtual_plane_option = command->add_option(
      "--virtual-plane", line.virtual_plane_m,
      "moment_depth: depth in metres of the virtual plane whose occlusion is computed "
      "(default: the middle of the map's range)");
  return command;
}

int RunClientCommand(ClientCommandLine& line) {
  ::transient::tools::ClientArgs& args = line.args;
  args.products = absl::StrSplit(line.products, ',', absl::SkipWhitespace());
  for (std::string& product : args.products) {
    product = std::string(absl::StripAsciiWhitespace(product));
  }
  if (!line.roi.empty()) {
    absl::StatusOr<::transient::tools::ClientRoi> roi = ::transient::tools::ParseRoi(line.roi);
    if (!roi.ok()) {
      std::cerr << ErrorLine(roi.status()) << "\n";
      return kExitBadInput;
    }
    args.roi = *roi;
  }
  // --seconds alone replaces the default --frames.
  if (line.seconds_option->count() > 0 && line.frames_option->count() == 0) args.frames = 0;
  if (line.moment_sigma_option->count() > 0) args.moment_sigma_px = line.moment_sigma_px;
  if (line.virtual_plane_option->count() > 0) args.virtual_plane_m = line.virtual_plane_m;
  if (absl::Status status = args.Validate(); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  return RunWithProgress<::transient::tools::ClientSummary>(
      [&](const ::transient::tools::CommandHooks& hooks) {
        return ::transient::tools::RunClient(args, hooks);
      },
      ::transient::tools::FormatClientSummary);
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddClientCommand(app, line_); }
  int Run() override { return RunClientCommand(line_); }

 private:
  ClientCommandLine line_;
};

}  // namespace client_cli

std::unique_ptr<Subcommand> MakeClientCommand() {
  return std::make_unique<client_cli::Command>();
}

}  // namespace transient::tools::cli

// The `transient` command line: subcommands over the tool library. This file only maps
// arguments to the commands' argument structs and statuses to messages and exit codes.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <functional>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "transient/drivers/simulator.h"
#include "transient/drivers/source_registry.h"
#include "tools/eval/eval_command.h"
#include "tools/transient/bench_command.h"
#include "tools/transient/capture_commands.h"
#include "tools/transient/client_command.h"
#include "tools/transient/daemon_frame_source.h"
#include "tools/transient/exit_status.h"
#include "tools/transient/progress_bar.h"
#include "tools/transient/reconstruct_command.h"
#include "tools/transient/view_command.h"
#include "transient/wire/product_registry.h"

namespace {

using transient::tools::ErrorLine;
using transient::tools::ExitCodeFor;
using transient::tools::kExitBadInput;

std::atomic<bool> interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");

// The first SIGINT/SIGTERM asks the running command to stop and clean up; a second one
// kills the process at once (the default action is restored).
extern "C" void OnInterrupt(int signal_number) {
  interrupted.store(true);
  std::signal(signal_number, SIG_DFL);
}

// The reconstruct subcommand's options as typed; turned into ReconstructArgs after parsing.
struct ReconstructCommandLine {
  transient::tools::ReconstructArgs args;
  std::string method = "both";
  std::string bias_mode = "raise";
  std::string zeroth = "measured";
  CLI::Option* zeroth_option = nullptr;
  double bounds_r = 0.0;
  CLI::Option* bounds_r_option = nullptr;
  std::string frames;
  CLI::Option* frames_option = nullptr;
};

CLI::App* AddReconstructCommand(CLI::App& app, ReconstructCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "reconstruct",
      "Reconstruct a moment file (transient-moments 1) into range, density, cumulative and "
      "Pisarenko images (transient-reconstruction 1). Layouts: README.md.");
  transient::tools::ReconstructArgs& args = line.args;
  command->add_option("input", args.input_path, "moment file to read (IN.h5)")->required();
  command
      ->add_option("output", args.output_path,
                   "reconstruction file to write (OUT.h5); replaced only when the run succeeds")
      ->required();
  command->add_option("--method", line.method, "mese, pisarenko or both")->capture_default_str();
  command
      ->add_option("--bins", args.bins,
                   "phases 2*pi*n/N of /density, /cumulative and /bounds (8..65536)")
      ->capture_default_str();
  command
      ->add_option("--bias-epsilon", args.bias_epsilon,
                   "bias so that lambda_min >= E * c_0 (1e-6 <= E < 1)")
      ->capture_default_str();
  command
      ->add_option("--bias-mode", line.bias_mode,
                   "raise (raise c_0) or scale (scale c_1..c_m down)")
      ->capture_default_str();
  line.zeroth_option =
      command
          ->add_option("--zeroth", line.zeroth,
                       "measured (c_0 from the file) or estimate (from c_1..c_m); default: what "
                       "the file's /moments attribute zeroth says, else measured")
          ->capture_default_str();
  command
      ->add_option("--threshold", args.threshold,
                   "a return counts when above T times the pixel's strongest (0 <= T < 1)")
      ->capture_default_str();
  line.bounds_r_option =
      command->add_option("--bounds-r", line.bounds_r,
                          "also write /bounds for the Poisson kernel radius R (0 < R < 1)");
  line.frames_option = command->add_option(
      "--frames", line.frames, "frames A:B to reconstruct, a Python slice (default: all)");
  return command;
}

absl::Status CompleteArgs(ReconstructCommandLine& line) {
  transient::tools::ReconstructArgs& args = line.args;
  absl::StatusOr<transient::tools::Method> method = transient::tools::ParseMethod(line.method);
  if (!method.ok()) return method.status();
  args.method = *method;
  absl::StatusOr<transient::BiasMode> bias_mode = transient::tools::ParseBiasMode(line.bias_mode);
  if (!bias_mode.ok()) return bias_mode.status();
  args.bias_mode = *bias_mode;
  absl::StatusOr<transient::ZerothMoment> zeroth = transient::tools::ParseZeroth(line.zeroth);
  if (!zeroth.ok()) return zeroth.status();
  args.zeroth = *zeroth;
  args.zeroth_from_file = line.zeroth_option->count() == 0;
  if (line.bounds_r_option->count() > 0) args.bounds_r = line.bounds_r;
  if (line.frames_option->count() > 0) {
    absl::StatusOr<transient::tools::FrameSlice> frames =
        transient::tools::ParseFrameSlice(line.frames);
    if (!frames.ok()) return frames.status();
    args.frames = *frames;
  }
  return args.Validate();
}

int RunReconstructCommand(ReconstructCommandLine& line) {
  if (absl::Status status = CompleteArgs(line); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);

  std::unique_ptr<transient::tools::ProgressBar> progress;
  transient::tools::ReconstructHooks hooks{
      .on_frame =
          [&](int64_t done, int64_t total) {
            if (progress == nullptr) {
              progress = std::make_unique<transient::tools::ProgressBar>(stderr, total);
            }
            progress->Update(done);
          },
      .cancel = &interrupted,
  };
  absl::StatusOr<transient::tools::ReconstructSummary> summary =
      transient::tools::RunReconstruct(line.args, hooks);
  progress.reset();  // erase the bar before anything else is printed
  if (!summary.ok()) {
    std::cerr << ErrorLine(summary.status()) << "\n";
    return ExitCodeFor(summary.status());
  }
  std::cout << transient::tools::FormatSummary(*summary) << "\n";
  return 0;
}

struct BenchCommandLine {
  transient::tools::BenchArgs args;
};

CLI::App* AddBenchCommand(CLI::App& app, BenchCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "bench",
      "Time the optimized kernels against the scalar reference in one run (163x120 and "
      "640x480 synthetic frames) and print their ratio.");
  command->add_option("--json", line.args.json_path, "also write the table as JSON here");
  command->add_option("--min-time", line.args.min_seconds, "seconds per measurement")
      ->capture_default_str();
  command->add_option("--threads", line.args.threads, "thread counts of the optimized kernels")
      ->capture_default_str();
  return command;
}

int RunBenchCommand(const BenchCommandLine& line) {
  if (absl::Status status = line.args.Validate(); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  std::fprintf(stderr, "transient bench: reference vs optimized, one row at a time...\n");
  absl::StatusOr<std::vector<transient::tools::BenchRow>> rows =
      transient::tools::RunBench(line.args, [](const transient::tools::BenchRow& row) {
        std::fprintf(stderr, "  %s, m = %d, %dx%d, %d thread(s): %.1fx\n", row.kernel.c_str(),
                     row.order, row.width, row.height, row.threads, row.ratio());
      });
  if (!rows.ok()) {
    std::cerr << ErrorLine(rows.status()) << "\n";
    return ExitCodeFor(rows.status());
  }
  std::cout << transient::tools::FormatBenchTable(*rows);
  if (!line.args.json_path.empty()) {
    std::FILE* file = std::fopen(line.args.json_path.c_str(), "w");
    const std::string json = transient::tools::FormatBenchJson(*rows);
    if (file == nullptr || std::fwrite(json.data(), 1, json.size(), file) != json.size() ||
        std::fclose(file) != 0) {
      std::cerr << "error: " << line.args.json_path << ": cannot write the JSON file\n";
      return kExitBadInput;
    }
    std::cout << "wrote " << line.args.json_path << "\n";
  }
  return 0;
}

// Runs `run` with SIGINT/SIGTERM handling and a progress bar; prints its summary or its error.
template <typename Summary>
int RunWithProgress(const std::function<absl::StatusOr<Summary>(
                        const transient::tools::CommandHooks&)>& run,
                    const std::function<std::string(const Summary&)>& format) {
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  std::unique_ptr<transient::tools::ProgressBar> progress;
  transient::tools::CommandHooks hooks{
      .on_progress =
          [&](int64_t done, int64_t total) {
            if (progress == nullptr) {
              progress = std::make_unique<transient::tools::ProgressBar>(stderr, total);
            }
            progress->Update(done);
          },
      .cancel = &interrupted,
  };
  absl::StatusOr<Summary> summary = run(hooks);
  progress.reset();
  if (!summary.ok()) {
    std::cerr << ErrorLine(summary.status()) << "\n";
    return ExitCodeFor(summary.status());
  }
  std::cout << format(*summary) << "\n";
  return 0;
}

// Keys of the simulator URI that `transient sim` offers as options of their own.
struct SimCommandLine {
  std::string scene;
  transient::tools::RecordArgs record;
  int64_t frames = 10;
  std::vector<std::string> keys;  // --set key=value
  // Options mapped onto URI keys when given.
  std::vector<std::pair<std::string, std::string>> options = {
      {"m", ""}, {"f", ""}, {"scheme", ""}, {"nphi", ""}, {"zeroth", ""}, {"takes", ""},
      {"noise", ""}, {"snr", ""}, {"seed", ""}, {"camera_seed", ""}, {"width", ""},
      {"height", ""}, {"waveform", ""}, {"outliers", ""}};
};

std::string SimHelp() {
  std::string text = "Scenes:\n";
  for (const transient::SimulatorScene& scene : transient::SimulatorScenes()) {
    absl::StrAppend(&text, "  ", scene.name, ": ", scene.description, "\n");
  }
  absl::StrAppend(&text, "Keys for --set key=value (URI sim:<scene>?key=value&...):\n");
  for (const transient::SourceKey& key : transient::SimulatorKeys()) {
    absl::StrAppend(&text, "  ", key.name, " (default ", key.default_value,
                    key.unit.empty() ? "" : absl::StrCat(" ", key.unit), "): ", key.description,
                    "\n");
  }
  return text;
}

CLI::App* AddSimCommand(CLI::App& app, SimCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "sim", "Simulate an AMCW camera looking at a scene and record it as a capture file "
             "(transient-capture 1) with the scene's ground truth.");
  command->footer(SimHelp());
  command->add_option("scene", line.scene, "mirrors, corner, sparse, video or calibration")
      ->required();
  command->add_option("--out", line.record.output_path, "capture file to write (must not exist)")
      ->required();
  command->add_option("--frames", line.frames, "transient frames (capture cycles) to simulate")
      ->capture_default_str();
  for (auto& [key, value] : line.options) {
    std::string flag = "--" + key;
    for (char& c : flag) c = c == '_' ? '-' : c;
    command->add_option(flag, value, "the simulator key " + key + " (see below)");
  }
  command->add_option("--set", line.keys, "any simulator key as key=value (repeatable)");
  command->add_option("--deflate", line.record.deflate_level, "deflate level 0..9")
      ->capture_default_str();
  return command;
}

int RunSimCommand(SimCommandLine& line) {
  std::vector<std::string> keys;
  for (const auto& [key, value] : line.options) {
    if (!value.empty()) keys.push_back(key + "=" + value);
  }
  keys.insert(keys.end(), line.keys.begin(), line.keys.end());
  absl::StatusOr<std::string> uri = transient::SimulatorUri(line.scene, line.frames, keys);
  if (!uri.ok()) {
    std::cerr << ErrorLine(uri.status()) << "\n";
    return kExitBadInput;
  }
  line.record.source_uri = *uri;
  line.record.frames = line.frames;
  return RunWithProgress<transient::tools::RecordSummary>(
      [&](const transient::tools::CommandHooks& hooks) {
        return transient::tools::RunRecord(line.record, hooks);
      },
      transient::tools::FormatRecordSummary);
}

CLI::App* AddRecordCommand(CLI::App& app, transient::tools::RecordArgs& args) {
  CLI::App* command = app.add_subcommand(
      "record", "Record raw frames from a source into a capture file (transient-capture 1); "
                "flushed at least once a second, readable after a crash up to the last flush.");
  command->add_option("--source", args.source_uri, "source URI (see transient sources)")
      ->required();
  command->add_option("--out", args.output_path, "capture file to write (must not exist)")
      ->required();
  command->add_option("--frames", args.frames, "transient frames (capture cycles) to record");
  command->add_option("--seconds", args.seconds, "wall-clock seconds to record");
  command->add_option("--deflate", args.deflate_level, "deflate level 0..9")
      ->capture_default_str();
  return command;
}

CLI::App* AddCalibrateCommand(CLI::App& app, transient::tools::CalibrateArgs& args) {
  CLI::App* command = app.add_subcommand(
      "calibrate",
      "Measure per-pixel, per-harmonic correction factors against a Dirac at zero (thesis "
      "§8.3.2) and write a calibration file (transient-calibration 1). Use the same camera and "
      "schedule as the captures it will correct.");
  command->add_option("--source", args.source_uri,
                      "source looking at a Dirac at zero, e.g. sim:calibration?m=3")
      ->capture_default_str();
  command->add_option("--out", args.output_path, "calibration file to write")->required();
  command->add_option("--takes", args.takes, "capture cycles to average (1..256)")
      ->capture_default_str();
  return command;
}

CLI::App* AddMomentsCommand(CLI::App& app, transient::tools::MomentsArgs& args) {
  CLI::App* command = app.add_subcommand(
      "moments", "Demodulate and calibrate a capture into a moment file (transient-moments 1) "
                 "for transient reconstruct.");
  command->add_option("capture", args.capture_path, "capture file (transient-capture 1)")
      ->required();
  command->add_option("--out", args.output_path, "moment file to write")->required();
  command->add_option("--calibration", args.calibration_path,
                      "calibration file (default: the one embedded in the capture)");
  command->add_flag("--uncalibrated", args.uncalibrated, "demodulate without a calibration");
  command->add_option("--smooth", args.smoothing_sigma_px,
                      "Gaussian smoothing sigma in pixels, 0 = none (thesis §8.5)")
      ->capture_default_str();
  command->add_flag("--video", args.video,
                    "fill outlier captures from the previous frame and flag them (thesis §8.5)");
  return command;
}

CLI::App* AddInfoCommand(CLI::App& app, std::string& path) {
  CLI::App* command = app.add_subcommand(
      "info", "Say what a file is (capture, calibration, moments, reconstruction), its layout "
              "and a summary of its content.");
  command->add_option("file", path, "HDF5 file")->required();
  return command;
}

int RunInfoCommand(const std::string& path) {
  absl::StatusOr<std::string> text = transient::tools::DescribeFile(path);
  if (!text.ok()) {
    std::cerr << ErrorLine(text.status()) << "\n";
    return ExitCodeFor(text.status());
  }
  std::cout << *text << "\n";
  return 0;
}

// The client subcommand's options as typed; turned into ClientArgs after parsing.
struct ClientCommandLine {
  transient::tools::ClientArgs args;
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
  transient::tools::ClientArgs& args = line.args;
  command->add_option("--connect", args.connect, "address of transientd, host:port or unix:PATH")
      ->capture_default_str();
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
  transient::tools::ClientArgs& args = line.args;
  args.products = absl::StrSplit(line.products, ',', absl::SkipWhitespace());
  for (std::string& product : args.products) {
    product = std::string(absl::StripAsciiWhitespace(product));
  }
  if (!line.roi.empty()) {
    absl::StatusOr<transient::tools::ClientRoi> roi = transient::tools::ParseRoi(line.roi);
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
  return RunWithProgress<transient::tools::ClientSummary>(
      [&](const transient::tools::CommandHooks& hooks) {
        return transient::tools::RunClient(args, hooks);
      },
      transient::tools::FormatClientSummary);
}

// The view subcommand's options as typed; turned into ViewArgs after parsing.
struct ViewCommandLine {
  transient::tools::ViewArgs args;
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
  transient::tools::ViewArgs& args = line.args;
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
  command
      ->add_option("--connect-timeout", args.connect_timeout_s,
                   "daemon input: seconds to wait for transientd to accept the connection")
      ->capture_default_str();

  transient::tools::MomentPictureOptions& moment = args.moment;
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
  transient::tools::ViewArgs& args = line.args;
  for (const std::string& text : line.pixels) {
    absl::StatusOr<transient::tools::PixelPosition> pixel =
        transient::tools::ParsePixelPosition(text);
    if (!pixel.ok()) {
      std::cerr << ErrorLine(pixel.status()) << "\n";
      return kExitBadInput;
    }
    args.pixels.push_back(*pixel);
  }
  absl::StatusOr<transient::tools::PlyFormat> ply = transient::tools::ParsePlyFormat(line.ply_format);
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
  if (line.frames_option->count() > 0 && transient::tools::IsDaemonInput(args.input_path)) {
    if (!absl::SimpleAtoi(line.frames, &args.daemon_frames)) {
      std::cerr << ErrorLine(absl::InvalidArgumentError(absl::StrCat(
                       "--frames = '", line.frames,
                       "': a daemon input takes the number of frames to receive")))
                << "\n";
      return kExitBadInput;
    }
  } else if (line.frames_option->count() > 0) {
    absl::StatusOr<transient::tools::FrameSlice> frames =
        transient::tools::ParseFrameSlice(line.frames);
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
  return RunWithProgress<transient::tools::ViewSummary>(
      [&](const transient::tools::CommandHooks& hooks) {
        return transient::tools::RunView(args, hooks);
      },
      transient::tools::FormatViewSummary);
}

CLI::App* AddEvalCommand(CLI::App& app, transient::eval::EvalArgs& args) {
  CLI::App* command = app.add_subcommand(
      "eval",
      "Quality benchmark (thesis fig. 8.12, 8.13): MESE and Pisarenko against single-frequency "
      "phase, Godbaz et al., SPUMIC and SRA on synthetic responses and the simulated corner; "
      "writes eval.md, eval.json and SVG plots.");
  command->add_option("--out", args.output_dir, "directory to write into (created if missing)")
      ->capture_default_str();
  command->add_option("--trials", args.trials, "trials per configuration (> 0)")
      ->capture_default_str();
  command->add_option("--seed", args.seed, "seed of the ground truths and the noise")
      ->capture_default_str();
  return command;
}

int RunEvalCommand(const transient::eval::EvalArgs& args) {
  if (absl::Status status = args.Validate(); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  transient::eval::ExperimentHooks hooks{
      .on_progress = nullptr,
      .on_stage = [](const std::string& line) { std::cerr << "transient eval: " << line << "\n"; },
      .cancel = &interrupted,
  };
  absl::StatusOr<transient::eval::EvalSummary> summary = transient::eval::RunEval(args, hooks);
  if (!summary.ok()) {
    std::cerr << ErrorLine(summary.status()) << "\n";
    return ExitCodeFor(summary.status());
  }
  std::cout << transient::eval::FormatEvalSummary(*summary) << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("transient: transient images and depth from AMCW time-of-flight moments",
               "transient");
  app.set_version_flag("--version", TRANSIENT_VERSION);
  app.require_subcommand(1);
  ReconstructCommandLine reconstruct_line;
  CLI::App* reconstruct = AddReconstructCommand(app, reconstruct_line);
  BenchCommandLine bench_line;
  CLI::App* bench = AddBenchCommand(app, bench_line);
  SimCommandLine sim_line;
  CLI::App* sim = AddSimCommand(app, sim_line);
  transient::tools::RecordArgs record_args;
  CLI::App* record = AddRecordCommand(app, record_args);
  transient::tools::CalibrateArgs calibrate_args;
  CLI::App* calibrate = AddCalibrateCommand(app, calibrate_args);
  transient::tools::MomentsArgs moments_args;
  CLI::App* moments = AddMomentsCommand(app, moments_args);
  std::string info_path;
  CLI::App* info = AddInfoCommand(app, info_path);
  CLI::App* sources = app.add_subcommand(
      "sources", "List the capture source URI schemes, their keys with defaults and units, and "
                 "what each source can do.");
  ClientCommandLine client_line;
  CLI::App* client = AddClientCommand(app, client_line);
  ViewCommandLine view_line;
  CLI::App* view = AddViewCommand(app, view_line);
  transient::eval::EvalArgs eval_args;
  CLI::App* eval = AddEvalCommand(app, eval_args);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    if (error.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) {
      return app.exit(error);  // --help, --version
    }
    std::cerr << "error: " << error.what() << " (see transient --help)\n";
    return kExitBadInput;
  }
  if (reconstruct->parsed()) return RunReconstructCommand(reconstruct_line);
  if (bench->parsed()) return RunBenchCommand(bench_line);
  if (sim->parsed()) return RunSimCommand(sim_line);
  if (record->parsed()) {
    return RunWithProgress<transient::tools::RecordSummary>(
        [&](const transient::tools::CommandHooks& hooks) {
          return transient::tools::RunRecord(record_args, hooks);
        },
        transient::tools::FormatRecordSummary);
  }
  if (calibrate->parsed()) {
    return RunWithProgress<transient::tools::CalibrateSummary>(
        [&](const transient::tools::CommandHooks& hooks) {
          return transient::tools::RunCalibrate(calibrate_args, hooks);
        },
        transient::tools::FormatCalibrateSummary);
  }
  if (moments->parsed()) {
    return RunWithProgress<transient::tools::MomentsSummary>(
        [&](const transient::tools::CommandHooks& hooks) {
          return transient::tools::RunMoments(moments_args, hooks);
        },
        transient::tools::FormatMomentsSummary);
  }
  if (info->parsed()) return RunInfoCommand(info_path);
  if (sources->parsed()) {
    std::cout << transient::DescribeSourceSchemes();
    return 0;
  }
  if (client->parsed()) return RunClientCommand(client_line);
  if (view->parsed()) return RunViewCommand(view_line);
  if (eval->parsed()) return RunEvalCommand(eval_args);
  return kExitBadInput;  // unreachable: exactly one subcommand is required
}

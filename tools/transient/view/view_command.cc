// The view command: open the input as a frame source (view_inputs.h, DaemonFrameSource), then
// draw it (view_drawing.h: the plan, the colour scales in one pass over the frames, the pictures
// frame by frame).
#include "tools/transient/view/view_command.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <new>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "tools/transient/commands/reconstruct_command.h"
#include "tools/transient/view/daemon_frame_source.h"
#include "tools/transient/view/view_drawing.h"
#include "tools/transient/view/view_inputs.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/file_format.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/reconstruction_reader.h"
#include "transient/reconstruct/status_context.h"

namespace transient::tools {
namespace {

DaemonSourceOptions DaemonOptionsOf(const ViewArgs& args) {
  return {.address = args.input_path.substr(absl::string_view(kDaemonInputPrefix).size()),
          .frames = args.daemon_frames,
          .bins = args.bins,
          .connect_timeout_s = args.connect_timeout_s,
          .security = args.security};
}

// A daemon input: the frames are received first, then drawn like a file's.
absl::StatusOr<ViewSummary> ViewDaemon(const ViewArgs& args, const CommandHooks& hooks) {
  const auto start_time = std::chrono::steady_clock::now();
  absl::StatusOr<std::unique_ptr<DaemonFrameSource>> source =
      DaemonFrameSource::Receive(DaemonOptionsOf(args), hooks.cancel);
  if (!source.ok()) return source.status();
  ViewSummary summary{
      .input_path = args.input_path, .output_dir = args.output_dir, .input_kind = "transientd"};
  summary.notes = (*source)->notes();
  if (absl::Status status = DrawView(args, **source, (*source)->phases(), (*source)->intrinsics(),
                                 /*index_offset=*/0, hooks, summary);
      !status.ok()) {
    return status;
  }
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

absl::StatusOr<ViewSummary> View(const ViewArgs& args, const CommandHooks& hooks) {
  const auto start_time = std::chrono::steady_clock::now();
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  if (IsDaemonInput(args.input_path)) return ViewDaemon(args, hooks);
  absl::StatusOr<FileIdentity> input =
      IdentifyFile(args.input_path, "an HDF5 reconstruction, moment or capture file");
  if (!input.ok()) return input.status();
  ViewSummary summary{.input_path = args.input_path, .output_dir = args.output_dir};

  if (input->Is(FileFormat::kMoments) || input->Is(FileFormat::kCapture)) {
    const bool capture = input->Is(FileFormat::kCapture);
    summary.input_kind = capture ? "capture" : "moments";
    absl::StatusOr<MomentInput> moments =
        capture ? MeasureCaptureInput(args, hooks) : OpenMomentInput(args);
    if (!moments.ok()) return moments.status();
    if (absl::Status status = DrawView(args, *moments->source, moments->phases, moments->intrinsics,
                                   moments->first_index, hooks, summary);
        !status.ok()) {
      return status;
    }
    summary.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
    return summary;
  }
  if (!input->Is(FileFormat::kReconstruction)) {
    return absl::InvalidArgumentError(absl::StrCat(
        args.input_path, ": /: attribute format: expected '", kReconstructionFormatName, " ",
        kReconstructionFormatMajor, "', '", kMomentFormatName, " ", kMomentFormatMajor, "' or '",
        kCaptureFormatName, " ", kCaptureFormatMajor, "', found '", input->text, "'"));
  }
  summary.input_kind = "reconstruction";
  absl::StatusOr<ReconstructionReader> reader = ReconstructionReader::Open(args.input_path);
  if (!reader.ok()) return reader.status();
  // The frames to draw, as a view of the reader's frames.
  absl::StatusOr<FrameRange> range = ResolveFrameSlice(args.frames, reader->frames());
  if (!range.ok()) return WithContext(args.input_path, range.status());
  const ReconstructionWindow source(*reader, *range, args.input_path);
  if (absl::Status status =
          DrawView(args, source, reader->phases(), std::nullopt, range->first, hooks, summary);
      !status.ok()) {
    return status;
  }
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

}  // namespace

absl::StatusOr<PixelPosition> ParsePixelPosition(const std::string& text) {
  const std::vector<std::string> parts = absl::StrSplit(text, ',');
  PixelPosition pixel;
  if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &pixel.x) ||
      !absl::SimpleAtoi(parts[1], &pixel.y)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--pixel = '", text, "': expected two integers X,Y"));
  }
  return pixel;
}

absl::StatusOr<PlyFormat> ParsePlyFormat(const std::string& text) {
  if (text == "ascii") return PlyFormat::kAscii;
  if (text == "binary") return PlyFormat::kBinary;
  return absl::InvalidArgumentError(
      absl::StrCat("--ply-format = '", text, "': expected ascii or binary"));
}

absl::Status ViewArgs::Validate() const {
  if (input_path.empty()) return absl::InvalidArgumentError("input file: the path is empty");
  if (output_dir.empty()) return absl::InvalidArgumentError("--out: the path is empty");
  if (IsDaemonInput(input_path)) {
    if (frames.start.has_value() || frames.stop.has_value()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--frames = '", frames.ToString(),
          "': a daemon input takes the number of frames to receive, not a slice"));
    }
    if (absl::Status status = DaemonOptionsOf(*this).Validate(); !status.ok()) return status;
  }
  for (double tau : tau_ns) {
    if (!std::isfinite(tau) || tau < 0.0) {
      return absl::InvalidArgumentError(
          absl::StrCat("--tau = ", tau, ": expected a finite time of flight >= 0 ns"));
    }
  }
  for (int row : streak_rows) {
    if (row < 0) {
      return absl::InvalidArgumentError(absl::StrCat("--streak = ", row, ": expected y >= 0"));
    }
  }
  for (const PixelPosition& pixel : pixels) {
    if (pixel.x < 0 || pixel.y < 0) {
      return absl::InvalidArgumentError(absl::StrCat("--pixel = ", pixel.x, ",", pixel.y,
                                                     ": expected x >= 0 and y >= 0"));
    }
  }
  if (density_scale.has_value() && !(std::isfinite(*density_scale) && *density_scale > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--scale = ", *density_scale, ": expected a finite value > 0"));
  }
  if (!(fps > 0.0 && fps <= 240.0)) {
    return absl::InvalidArgumentError(absl::StrCat("--fps = ", fps, ": expected 0 < fps <= 240"));
  }
  if (bins < kMinBins || bins > kMaxBins) {
    return absl::InvalidArgumentError(
        absl::StrCat("--bins = ", bins, ": expected an integer in ", kMinBins, "..", kMaxBins));
  }
  if (bounds_r.has_value() && !(*bounds_r > 0.0 && *bounds_r < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--bounds-r = ", *bounds_r, ": expected 0 < R < 1"));
  }
  return moment.Validate();
}

std::string FormatViewSummary(const ViewSummary& summary) {
  std::string text = absl::StrFormat(
      "drew %d frame%s of %dx%d px (%s %s): %d PNG, %d PLY", summary.frames,
      summary.frames == 1 ? "" : "s", summary.geometry.width, summary.geometry.height,
      summary.input_kind, summary.input_path, summary.png_files, summary.ply_files);
  if (summary.video_frames > 0) {
    absl::StrAppendFormat(&text, ", light.mp4 with %d video frames", summary.video_frames);
  }
  if (summary.moment_video_frames > 0) {
    absl::StrAppendFormat(&text, ", moment_plane.mp4 with %d video frames",
                          summary.moment_video_frames);
  }
  absl::StrAppend(&text, " -> ", summary.output_dir);
  if (summary.density_drawn) {
    absl::StrAppendFormat(&text, "; density scale 0..%.4g %s (%s)", summary.scales.density,
                          kDensityUnit,
                          summary.density_scale_given ? "--scale" : "99.5th percentile");
  }
  absl::StrAppendFormat(&text, ", %.2f s", summary.seconds);
  if (summary.moment.has_value()) {
    absl::StrAppend(&text, "\n  ", FormatMomentSetup(*summary.moment));
  }
  for (const std::string& note : summary.notes) absl::StrAppend(&text, "\n  note: ", note);
  return text;
}

absl::StatusOr<ViewSummary> RunView(const ViewArgs& args, const CommandHooks& hooks) {
  // Exceptions (an allocation that fails, OpenCV) become statuses here.
  try {
    return View(args, hooks);
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError(absl::StrCat(args.input_path, ": out of memory"));
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat(args.input_path, ": ", e.what()));
  }
}

}  // namespace transient::tools

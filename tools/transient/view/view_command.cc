// The view command: check everything asked for against the input, choose the colour scales in
// one pass over the frames, then draw frame by frame.
#include "tools/transient/view_command.h"


#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <numbers>
#include <system_error>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "tools/transient/capture_moments.h"
#include "tools/transient/daemon_frame_source.h"
#include "tools/transient/moment_frame_source.h"
#include "tools/transient/figure.h"
#include "transient/formats/moment_file.h"
#include "tools/transient/pixel_plot.h"
#include "tools/transient/reconstruct_command.h"
#include "transient/formats/reconstruction_reader.h"
#include "tools/transient/video_file.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/file_format.h"

namespace transient::tools {
namespace {

absl::Status InFile(const std::string& file, const absl::Status& status) {
  return absl::Status(status.code(), absl::StrCat(file, ": ", status.message()));
}

// What a run draws, resolved against the input.
struct Plan {
  bool slices = false, cumulative = false, video = false, images = false, point_cloud = false;
  bool moment_depth = false;     // frame_NNN/moment_depth/ (moment_pictures.h)
  bool direct_indirect = false;  // part of images when the input has Pisarenko products
  bool pisarenko_range = false;  // likewise; a daemon sends direct/indirect without it
  std::vector<int> streak_rows;
  std::vector<PixelPosition> pixels;
  std::vector<int> bins;  // bins drawn by slices, cumulative and video
  std::optional<PinholeIntrinsics> intrinsics;
  ProductSet wanted;  // planes read per frame
};

DaemonSourceOptions DaemonOptionsOf(const ViewArgs& args) {
  return {.address = args.input_path.substr(absl::string_view(kDaemonInputPrefix).size()),
          .frames = args.daemon_frames,
          .bins = args.bins,
          .connect_timeout_s = args.connect_timeout_s};
}

bool NothingChosen(const ViewArgs& args) {
  return !args.slices && !args.cumulative && !args.video && !args.images && !args.point_cloud &&
         args.streak_rows.empty() && args.pixels.empty() && !args.moment.enabled;
}

// The bin whose phase is nearest (on the circle) to the time of flight tau.
int NearestBin(const TransientFrameSource& source, const std::vector<double>& phases,
               double tau_ns) {
  const double two_pi = 2.0 * std::numbers::pi;
  const double phi = two_pi * source.base_frequency_hz() * tau_ns * 1e-9;
  int best = 0;
  double best_distance = two_pi;
  for (int n = 0; n < static_cast<int>(phases.size()); ++n) {
    double distance = std::fmod(std::abs(phases[n] - phi), two_pi);
    distance = std::min(distance, two_pi - distance);
    if (distance < best_distance) best = n, best_distance = distance;
  }
  return best;
}

absl::StatusOr<PinholeIntrinsics> IntrinsicsOf(const CaptureReader& capture, ImageGeometry expected) {
  const CameraInfo& camera = capture.camera();
  if (camera.geometry != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        capture.path(), ": /camera: ", camera.geometry.width, "x", camera.geometry.height,
        " px, expected the reconstruction's ", expected.width, "x", expected.height, " px"));
  }
  const PinholeIntrinsics& intrinsics = camera.intrinsics;
  if (absl::Status status = intrinsics.Validate(); !status.ok()) {
    return InFile(absl::StrCat(capture.path(), ": /camera"), status);
  }
  return intrinsics;
}

// Checks what `args` asks for against `source` and resolves it into a plan.
absl::StatusOr<Plan> MakePlan(const ViewArgs& args, const TransientFrameSource& source,
                              const std::vector<double>& phases,
                              std::optional<PinholeIntrinsics> input_intrinsics) {
  const ProductSet available = source.available();
  const auto has = [&](Product product) { return available[static_cast<int>(product)]; };
  const bool all = NothingChosen(args);
  const ImageGeometry geometry = source.geometry();
  Plan plan;
  plan.slices = args.slices || all;
  plan.cumulative = args.cumulative || all;
  plan.video = args.video || all;
  plan.images = args.images || all;
  plan.streak_rows = args.streak_rows;
  plan.pixels = args.pixels;
  if (all) {
    plan.streak_rows.push_back(geometry.height / 2);
    plan.pixels.push_back({geometry.width / 2, geometry.height / 2});
  }

  const std::string& name = source.name();
  const auto need = [&](bool asked, Product product, const char* what) -> absl::Status {
    if (!asked || has(product)) return absl::OkStatus();
    return absl::NotFoundError(absl::StrCat(name, ": has no dataset ", ProductPath(product),
                                            ", which ", what, " need"));
  };
  // Pictures chosen explicitly must be possible; "everything" skips what the input lacks.
  if (all) {
    plan.slices = plan.slices && has(Product::kDensity);
    plan.video = plan.video && has(Product::kDensity);
    plan.cumulative = plan.cumulative && has(Product::kCumulative);
    if (!has(Product::kDensity)) plan.streak_rows.clear();
  }
  for (absl::Status status :
       {need(plan.slices, Product::kDensity, "density slices (--slices)"),
        need(plan.video, Product::kDensity, "the video (--video)"),
        need(!plan.streak_rows.empty(), Product::kDensity, "streak images (--streak)"),
        need(plan.cumulative, Product::kCumulative, "cumulative frames (--cumulative)")}) {
    if (!status.ok()) return status;
  }
  plan.direct_indirect = plan.images && has(Product::kPisarenkoDirect);
  plan.pisarenko_range = plan.images && has(Product::kPisarenkoRange);

  const double period_ns = 1e9 / source.base_frequency_hz();
  for (double tau : args.tau_ns) {
    if (!(tau >= 0.0 && tau < period_ns)) {
      return absl::OutOfRangeError(absl::StrFormat(
          "--tau = %g ns: expected 0 <= tau < %.4g ns, one period of %s's base frequency %g MHz",
          tau, period_ns, name, source.base_frequency_hz() * 1e-6));
    }
  }
  if (plan.slices || plan.cumulative || plan.video) {
    if (args.tau_ns.empty()) {
      for (int n = 0; n < static_cast<int>(phases.size()); ++n) plan.bins.push_back(n);
    } else {
      for (double tau : args.tau_ns) plan.bins.push_back(NearestBin(source, phases, tau));
    }
  }
  for (int row : plan.streak_rows) {
    if (row < 0 || row >= geometry.height) {
      return absl::OutOfRangeError(absl::StrCat("--streak = ", row, ": scanline outside ", name,
                                                "'s image, expected 0 <= y < ", geometry.height));
    }
  }
  for (const PixelPosition& pixel : plan.pixels) {
    if (pixel.x < 0 || pixel.x >= geometry.width || pixel.y < 0 || pixel.y >= geometry.height) {
      return absl::OutOfRangeError(absl::StrCat(
          "--pixel = ", pixel.x, ",", pixel.y, ": outside ", name, "'s image of ", geometry.width,
          "x", geometry.height, " px, expected 0 <= x < ", geometry.width, " and 0 <= y < ",
          geometry.height));
    }
  }

  if (!args.camera_path.empty()) {
    absl::StatusOr<CaptureReader> camera = CaptureReader::Open(args.camera_path);
    if (!camera.ok()) return camera.status();
    absl::StatusOr<PinholeIntrinsics> intrinsics = IntrinsicsOf(*camera, geometry);
    if (!intrinsics.ok()) return intrinsics.status();
    plan.intrinsics = *intrinsics;
  } else {
    plan.intrinsics = input_intrinsics;
  }
  plan.point_cloud = args.point_cloud || (all && plan.intrinsics.has_value());
  if (plan.point_cloud && !plan.intrinsics.has_value()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--point-cloud needs the camera's intrinsics: give --camera CAPTURE.h5 (a capture file "
        "of the camera that took ", name, ")"));
  }
  plan.moment_depth = args.moment.enabled;
  if (plan.moment_depth) {
    if (!plan.intrinsics.has_value()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--moment-depth needs the camera's intrinsics to turn range into depth: give --camera "
          "CAPTURE.h5 (a capture file of the camera that took ",
          name, ")"));
    }
    if (absl::Status status = need(true, Product::kRange, "the moment pictures (--moment-depth)");
        !status.ok()) {
      return status;
    }
    if (absl::Status status = CheckMomentOptionsForImage(args.moment, geometry); !status.ok()) {
      return status;
    }
  }

  ProductSet& wanted = plan.wanted;
  const auto want = [&](Product product) {
    if (has(product)) wanted.set(static_cast<int>(product));
  };
  if (plan.slices || plan.video || !plan.streak_rows.empty()) want(Product::kDensity);
  if (plan.cumulative) want(Product::kCumulative);
  if (plan.images || plan.point_cloud || !plan.pixels.empty() || plan.moment_depth) {
    want(Product::kRange);
    want(Product::kZerothMoment);
    want(Product::kFlags);
  }
  if (plan.images) {
    for (Product product : {Product::kPisarenkoDirect, Product::kPisarenkoIndirect,
                            Product::kPisarenkoRange}) {
      want(product);
    }
  }
  if (!plan.pixels.empty()) {
    for (Product product :
         {Product::kDensity, Product::kCumulative, Product::kPisarenkoPhase,
          Product::kPisarenkoWeight, Product::kPisarenkoUniform, Product::kBoundsLower,
          Product::kBoundsUpper}) {
      want(product);
    }
  }
  return plan;
}

// One pass over the frames to fix every colour scale for the whole run, and the depth
// percentiles of the moment pictures' defaults (`depth`, when the plan draws them).
absl::StatusOr<ViewScales> ChooseScales(const ViewArgs& args, const TransientFrameSource& source,
                                        const Plan& plan, const CommandHooks& hooks,
                                        DepthPercentiles* depth) {
  // The per-pixel plot scales its own axes; the colour-mapped pictures share these.
  const bool density =
      (plan.slices || plan.video || !plan.streak_rows.empty()) && !args.density_scale.has_value();
  const bool cumulative = plan.cumulative;
  const bool amplitude = plan.images || plan.point_cloud || plan.moment_depth;
  const bool range = plan.images;
  const bool optical_depth = plan.moment_depth;
  const bool direct_indirect = plan.direct_indirect;
  ViewScales scales;
  if (args.density_scale.has_value()) scales.density = *args.density_scale;
  if (!density && !cumulative && !amplitude && !range && !direct_indirect && !optical_depth) {
    return scales;
  }

  ProductSet wanted;
  if (density) wanted.set(static_cast<int>(Product::kDensity));
  if (cumulative) wanted.set(static_cast<int>(Product::kCumulative));
  if (amplitude) wanted.set(static_cast<int>(Product::kZerothMoment));
  if (range || optical_depth) wanted.set(static_cast<int>(Product::kRange));
  if (direct_indirect) {
    wanted.set(static_cast<int>(Product::kPisarenkoDirect));
    wanted.set(static_cast<int>(Product::kPisarenkoIndirect));
  }
  const int64_t pixels = source.geometry().pixel_count();
  const int64_t bin_values = source.frames() * std::max(source.bins(), 1) * pixels;
  const int64_t plane_values = source.frames() * pixels;
  const auto stride = [](int64_t values) {
    return std::max<int64_t>(1, (values + kMaxScaleSamples - 1) / kMaxScaleSamples);
  };
  ScaleSampler density_samples(stride(bin_values)), cumulative_samples(stride(bin_values));
  ScaleSampler amplitude_samples(stride(plane_values)), range_samples(stride(plane_values));
  ScaleSampler direct_indirect_samples(stride(2 * plane_values));
  ScaleSampler depth_samples(stride(plane_values));
  TransientFrame frame;
  for (int64_t k = 0; k < source.frames(); ++k) {
    if (hooks.cancel != nullptr && hooks.cancel->load()) {
      return absl::CancelledError("interrupted; nothing written");
    }
    if (absl::Status status = source.ReadFrame(k, wanted, &frame); !status.ok()) return status;
    if (density) density_samples.Add(frame.density);
    if (cumulative) cumulative_samples.Add(frame.cumulative);
    if (amplitude) amplitude_samples.Add(frame.c0);
    if (range) range_samples.Add(frame.range_m);
    if (optical_depth) {
      depth_samples.Add(DepthFromRange(frame.geometry, *plan.intrinsics, frame.range_m));
    }
    if (direct_indirect) {
      direct_indirect_samples.Add(frame.pisarenko_direct);
      direct_indirect_samples.Add(frame.pisarenko_indirect);
    }
  }
  if (density) scales.density = PositiveScale(density_samples.Quantile(kScaleQuantile, 1.0));
  if (cumulative) {
    scales.cumulative = PositiveScale(cumulative_samples.Quantile(kScaleQuantile, 1.0));
  }
  if (amplitude) scales.amplitude = PositiveScale(amplitude_samples.Quantile(kScaleQuantile, 1.0));
  if (direct_indirect) {
    scales.direct_indirect =
        PositiveScale(direct_indirect_samples.Quantile(kScaleQuantile, 1.0));
  }
  if (optical_depth) {
    // NaN when no pixel has a depth: ResolveMomentSetup then asks for every option.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    depth->low_m = depth_samples.Quantile(0.005, nan);
    depth->high_m = depth_samples.Quantile(0.95, nan);
    depth->top_m = depth_samples.Quantile(0.995, nan);
  }
  if (range) {
    scales.range_min_m = range_samples.Quantile(1.0 - kScaleQuantile, 0.0);
    scales.range_max_m = range_samples.Quantile(kScaleQuantile, 1.0);
    if (!(scales.range_max_m > scales.range_min_m)) {
      scales.range_max_m = scales.range_min_m + 1.0;
    }
  }
  return scales;
}

absl::Status MakeDirectory(const std::filesystem::path& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) return absl::OkStatus();
  if (std::filesystem::exists(path, error)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": exists and is not a directory"));
  }
  std::filesystem::create_directories(path, error);
  if (error) {
    return absl::PermissionDeniedError(
        absl::StrCat(path.string(), ": cannot create the directory (", error.message(), ")"));
  }
  return absl::OkStatus();
}

// Checks that the output directory can be made (or is one) without making it.
absl::Status CheckOutputDirectory(const std::string& output_dir) {
  std::filesystem::path path(output_dir);
  std::error_code error;
  if (std::filesystem::exists(path, error)) {
    if (!std::filesystem::is_directory(path, error)) {
      return absl::InvalidArgumentError(
          absl::StrCat(output_dir, ": exists and is not a directory"));
    }
    if (::access(output_dir.c_str(), W_OK) != 0) {
      return absl::PermissionDeniedError(absl::StrCat(output_dir, ": directory is not writable"));
    }
    return absl::OkStatus();
  }
  // The nearest existing ancestor must be a writable directory.
  std::filesystem::path ancestor = std::filesystem::absolute(path, error).parent_path();
  while (!ancestor.empty() && !std::filesystem::exists(ancestor, error)) {
    if (ancestor == ancestor.parent_path()) break;
    ancestor = ancestor.parent_path();
  }
  if (!std::filesystem::is_directory(ancestor, error) || ::access(ancestor.c_str(), W_OK) != 0) {
    return absl::PermissionDeniedError(absl::StrCat(
        output_dir, ": cannot be created (", ancestor.string(), " is not a writable directory)"));
  }
  return absl::OkStatus();
}

std::string FrameDirectoryName(int64_t index) { return absl::StrFormat("frame_%03d", index); }

// Draws every picture of the plan, frame by frame.
absl::Status DrawFrames(const ViewArgs& args, const TransientFrameSource& source,
                        const Plan& plan, const ViewScales& scales, int64_t index_offset,
                        const CommandHooks& hooks, MomentPictures* moment,
                        ViewSummary& summary) {
  const std::filesystem::path out(args.output_dir);
  if (absl::Status status = MakeDirectory(out); !status.ok()) return status;
  std::optional<Mp4Writer> video, moment_video;
  TransientFrame frame;
  const auto png = [&](const std::filesystem::path& path, const cv::Mat& figure) {
    ++summary.png_files;
    return WriteFigurePng(path.string(), figure);
  };
  for (int64_t k = 0; k < source.frames(); ++k) {
    if (hooks.cancel != nullptr && hooks.cancel->load()) {
      return absl::CancelledError("interrupted; the files written so far are complete");
    }
    if (absl::Status status = source.ReadFrame(k, plan.wanted, &frame); !status.ok()) {
      return status;
    }
    frame.index = index_offset + k;
    const std::filesystem::path dir = out / FrameDirectoryName(frame.index);
    if (absl::Status status = MakeDirectory(dir); !status.ok()) return status;
    if (plan.slices) {
      if (absl::Status status = MakeDirectory(dir / "slices"); !status.ok()) return status;
    }
    if (plan.cumulative) {
      if (absl::Status status = MakeDirectory(dir / "cumulative"); !status.ok()) return status;
    }
    for (int bin : plan.bins) {
      const std::string name = absl::StrFormat("slice_%03d.png", bin);
      if (plan.slices || plan.video) {
        const cv::Mat figure = RenderImageFigure(SliceFigure(frame, bin, scales.density));
        if (plan.slices) {
          if (absl::Status status = png(dir / "slices" / name, figure); !status.ok()) return status;
        }
        if (plan.video) {
          if (!video.has_value()) {
            absl::StatusOr<Mp4Writer> writer =
                Mp4Writer::Open((out / "light.mp4").string(), args.fps, figure.size());
            if (!writer.ok()) return writer.status();
            video.emplace(*std::move(writer));
          }
          if (absl::Status status = video->Write(figure); !status.ok()) return status;
        }
      }
      if (plan.cumulative) {
        const cv::Mat figure = RenderImageFigure(CumulativeFigure(frame, bin, scales.cumulative));
        if (absl::Status status = png(dir / "cumulative" / name, figure); !status.ok()) {
          return status;
        }
      }
    }
    for (int row : plan.streak_rows) {
      const cv::Mat figure = RenderImageFigure(StreakFigure(frame, row, scales.density));
      if (absl::Status status = png(dir / absl::StrFormat("streak_y%03d.png", row), figure);
          !status.ok()) {
        return status;
      }
    }
    if (plan.images) {
      std::vector<std::pair<std::string, ImageFigure>> figures;
      figures.emplace_back("range.png", RangeFigure(frame, scales));
      figures.emplace_back("amplitude.png", AmplitudeFigure(frame, scales.amplitude));
      figures.emplace_back("flags.png", FlagsFigure(frame));
      if (plan.direct_indirect) {
        figures.emplace_back("direct.png", DirectFigure(frame, scales.direct_indirect));
        figures.emplace_back("indirect.png", IndirectFigure(frame, scales.direct_indirect));
      }
      if (plan.pisarenko_range) {
        figures.emplace_back("range_pisarenko.png", RangeFigure(frame, scales, true));
      }
      for (const auto& [name, figure] : figures) {
        if (absl::Status status = png(dir / name, RenderImageFigure(figure)); !status.ok()) {
          return status;
        }
      }
    }
    if (plan.point_cloud) {
      const PointCloud cloud = PointsFromRange(
          frame.geometry, frame.range_m, *plan.intrinsics,
          args.ply_colour ? std::optional<std::span<const float>>(frame.c0) : std::nullopt,
          static_cast<float>(scales.amplitude));
      const PinholeIntrinsics& in = *plan.intrinsics;
      const std::vector<std::string> comments = {
          absl::StrCat("transient view: frame ", frame.index, " of ", source.name()),
          "points = range * normalize(((x - cx)/fx, (y - cy)/fy, 1)), metres, optical frame "
          "(x right, y down, z forward)",
          absl::StrFormat("intrinsics fx %.6g fy %.6g cx %.6g cy %.6g px", in.fx, in.fy, in.cx,
                          in.cy),
          args.ply_colour ? absl::StrFormat("colour: inferno of c0 over [0, %.6g]", scales.amplitude)
                          : "no colour"};
      ++summary.ply_files;
      if (absl::Status status =
              WritePly((dir / "points.ply").string(), cloud, args.ply_format, comments);
          !status.ok()) {
        return status;
      }
    }
    for (const PixelPosition& pixel : plan.pixels) {
      if (absl::Status status =
              png(dir / absl::StrFormat("pixel_x%03d_y%03d.png", pixel.x, pixel.y),
                  RenderPixelPlot(frame, pixel.x, pixel.y));
          !status.ok()) {
        return status;
      }
    }
    if (moment != nullptr) {
      const std::vector<float> depth =
          DepthFromRange(frame.geometry, *plan.intrinsics, frame.range_m);
      const std::vector<float> no_c0(depth.size(), std::numeric_limits<float>::quiet_NaN());
      if (absl::Status status = moment->SetFrame(frame.index, depth,
                                                 frame.c0.empty() ? no_c0 : frame.c0,
                                                 scales.amplitude);
          !status.ok()) {
        return status;
      }
      absl::StatusOr<int> written = moment->WriteFrame(dir / kMomentDirectory);
      if (!written.ok()) return written.status();
      summary.png_files += *written;
      if (args.moment.video) {
        const cv::Mat figure = moment->VideoFrameFigure();
        if (!moment_video.has_value()) {
          absl::StatusOr<Mp4Writer> writer =
              Mp4Writer::Open((out / "moment_plane.mp4").string(), args.fps, figure.size());
          if (!writer.ok()) return writer.status();
          moment_video.emplace(*std::move(writer));
        }
        if (absl::Status status = moment_video->Write(figure); !status.ok()) return status;
      }
    }
    if (hooks.on_progress) hooks.on_progress(k + 1, source.frames());
  }
  if (video.has_value()) {
    summary.video_frames = video->frames();
    if (absl::Status status = video->Close(); !status.ok()) return status;
  }
  if (moment_video.has_value()) {
    summary.moment_video_frames = moment_video->frames();
    if (absl::Status status = moment_video->Close(); !status.ok()) return status;
  }
  return absl::OkStatus();
}

// Everything after the input is open: the plan, the scales, the pictures.
absl::Status Draw(const ViewArgs& args, const TransientFrameSource& source,
                  const std::vector<double>& phases, std::optional<PinholeIntrinsics> input_intrinsics,
                  int64_t index_offset, const CommandHooks& hooks, ViewSummary& summary) {
  absl::StatusOr<Plan> plan = MakePlan(args, source, phases, input_intrinsics);
  if (!plan.ok()) return plan.status();
  if (absl::Status status = CheckOutputDirectory(args.output_dir); !status.ok()) return status;
  if (plan->images && !plan->direct_indirect) {
    summary.notes.push_back("no Pisarenko products in the input: no direct/indirect images");
  }
  if (NothingChosen(args) && !plan->point_cloud) {
    summary.notes.push_back("no point cloud: give --camera CAPTURE.h5 for the intrinsics");
  }
  if (NothingChosen(args) && !plan->slices) {
    summary.notes.push_back("no MESE density in the input: no slices, video or streak images");
  }

  DepthPercentiles depth;
  absl::StatusOr<ViewScales> scales = ChooseScales(args, source, *plan, hooks, &depth);
  if (!scales.ok()) return scales.status();
  // The moment pictures' range and placement are checked before anything is written.
  std::optional<MomentPictures> moment;
  if (plan->moment_depth) {
    absl::StatusOr<MomentSetup> setup =
        ResolveMomentSetup(args.moment, source.geometry(), *plan->intrinsics, depth);
    if (!setup.ok()) return setup.status();
    absl::StatusOr<MomentPictures> pictures = MomentPictures::Create(*setup);
    if (!pictures.ok()) return pictures.status();
    moment.emplace(*std::move(pictures));
    summary.moment = *setup;
  }
  summary.scales = *scales;
  summary.density_scale_given = args.density_scale.has_value();
  summary.density_drawn = plan->slices || plan->video || !plan->streak_rows.empty();
  summary.frames = source.frames();
  summary.geometry = source.geometry();
  return DrawFrames(args, source, *plan, *scales, index_offset, hooks,
                    moment.has_value() ? &*moment : nullptr, summary);
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
  if (absl::Status status = Draw(args, **source, (*source)->phases(), (*source)->intrinsics(),
                                 /*index_offset=*/0, hooks, summary);
      !status.ok()) {
    return status;
  }
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

// A window of `range` onto the reader, so that everything below sees only frames drawn.
class Window : public TransientFrameSource {
 public:
  Window(const ReconstructionReader& reader, FrameRange range, std::string name)
      : reader_(reader), range_(range), name_(std::move(name)) {}
  const std::string& name() const override { return name_; }
  int64_t frames() const override { return range_.count; }
  ImageGeometry geometry() const override { return reader_.geometry(); }
  double base_frequency_hz() const override { return reader_.base_frequency_hz(); }
  int bins() const override { return reader_.bins(); }
  ProductSet available() const override { return reader_.available(); }
  absl::Status ReadFrame(int64_t frame, ProductSet wanted,
                         TransientFrame* out) const override {
    return reader_.ReadFrame(range_.first + frame, wanted, out);
  }

 private:
  const ReconstructionReader& reader_;
  FrameRange range_;
  std::string name_;
};

// A moment or capture input, reconstructed frame by frame as it is drawn.
struct MomentInput {
  std::unique_ptr<MomentFrameSource> source = nullptr;
  std::vector<double> phases = {};
  std::optional<PinholeIntrinsics> intrinsics = std::nullopt;  // a capture's camera
  int64_t first_index = 0;                                     // index in the input of frame 0
};

// What `transient reconstruct` does by default, with the view's bins and bounds.
ReconstructionSettings ViewSettings(const ViewArgs& args, double base_frequency_hz,
                                    ZerothMoment zeroth) {
  return {.method = Method::kBoth,
          .solve = {.zeroth = zeroth},
          .base_frequency_hz = base_frequency_hz,
          .phases = UniformPhases(args.bins),
          .bounds_r = args.bounds_r};
}

absl::StatusOr<MomentInput> OpenMomentInput(const ViewArgs& args) {
  absl::StatusOr<MomentFile> file = MomentFile::Open(args.input_path);
  if (!file.ok()) return file.status();
  absl::StatusOr<FrameRange> range = ResolveFrameSlice(args.frames, file->frames());
  if (!range.ok()) return InFile(args.input_path, range.status());
  ReconstructionSettings settings = ViewSettings(
      args, file->base_frequency_hz(), file->zeroth_hint().value_or(ZerothMoment::kMeasured));
  MomentInput input{.phases = settings.phases, .first_index = range->first};
  input.source = MomentFrameSource::FromFile(args.input_path, *std::move(file), *range,
                                             std::move(settings));
  return input;
}

// A capture is measured through the frame pipeline (its moments held in memory, a few floats a
// pixel per frame), then reconstructed frame by frame as drawn.
absl::StatusOr<MomentInput> MeasureCaptureInput(const ViewArgs& args, const CommandHooks& hooks) {
  absl::StatusOr<CaptureReader> capture = CaptureReader::Open(args.input_path);
  if (!capture.ok()) return capture.status();
  if (!capture->calibration().has_value() && args.calibration_path.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        args.input_path, ": a capture without an embedded calibration: give --calibration "
                         "FILE (transient calibrate)"));
  }
  MomentInput input;
  absl::StatusOr<PinholeIntrinsics> intrinsics =
      IntrinsicsOf(*capture, capture->camera().geometry);
  if (intrinsics.ok()) input.intrinsics = *intrinsics;
  std::string calibration;
  absl::StatusOr<FramePipeline> pipeline =
      CapturePipeline(*capture, {.calibration_path = args.calibration_path}, &calibration);
  if (!pipeline.ok()) return pipeline.status();
  std::vector<MomentImage> frames;
  CaptureMeasureCounts counts;
  absl::Status measured = MeasureCapture(*capture, *pipeline, {.cancel = hooks.cancel}, &counts,
                                         [&](const MomentImage& moments, double) {
                                           frames.push_back(moments);
                                           return absl::OkStatus();
                                         });
  if (absl::IsCancelled(measured)) return absl::CancelledError("interrupted; nothing written");
  if (!measured.ok()) return measured;
  absl::StatusOr<FrameRange> range =
      ResolveFrameSlice(args.frames, static_cast<int64_t>(frames.size()));
  if (!range.ok()) return InFile(args.input_path, range.status());
  frames.erase(frames.begin() + range->first + range->count, frames.end());
  frames.erase(frames.begin(), frames.begin() + range->first);
  ReconstructionSettings settings =
      ViewSettings(args, capture->schedule().options().base_frequency_hz,
                   ZerothMomentOf(capture->schedule().options()));
  input.phases = settings.phases;
  input.first_index = range->first;
  input.source =
      MomentFrameSource::FromFrames(args.input_path, std::move(frames), std::move(settings));
  return input;
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
    if (absl::Status status = Draw(args, *moments->source, moments->phases, moments->intrinsics,
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
  if (!range.ok()) return InFile(args.input_path, range.status());
  const Window source(*reader, *range, args.input_path);
  if (absl::Status status =
          Draw(args, source, reader->phases(), std::nullopt, range->first, hooks, summary);
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

#include "tools/transient/view/view_drawing.h"

#include <unistd.h>

#include <filesystem>
#include <limits>
#include <span>
#include <system_error>
#include <utility>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tools/transient/view/figure.h"
#include "tools/transient/view/moment_pictures.h"
#include "tools/transient/view/pixel_plot.h"
#include "tools/transient/view/point_cloud.h"
#include "tools/transient/view/video_file.h"
#include "tools/transient/view/view_pictures.h"
#include "tools/transient/view/view_plan.h"
#include "tools/transient/view/view_scales.h"

namespace transient::tools {
namespace {

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

}  // namespace

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

namespace {

std::string FrameDirectoryName(int64_t index) { return absl::StrFormat("frame_%03d", index); }

// Draws every picture of the plan, frame by frame.
absl::Status DrawFrames(const ViewArgs& args, const TransientFrameSource& source,
                        const ViewPlan& plan, const ViewScales& scales, int64_t index_offset,
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
    if (hooks.cancelled()) {
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
    hooks.Progress(k + 1, source.frames());
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

}  // namespace

absl::Status DrawView(const ViewArgs& args, const TransientFrameSource& source,
                      const std::vector<double>& phases,
                      std::optional<PinholeIntrinsics> input_intrinsics, int64_t index_offset,
                      const CommandHooks& hooks, ViewSummary& summary) {
  absl::StatusOr<ViewPlan> plan = MakeViewPlan(args, source, phases, input_intrinsics);
  if (!plan.ok()) return plan.status();
  if (absl::Status status = CheckOutputDirectory(args.output_dir); !status.ok()) return status;
  if (plan->images && !plan->direct_indirect) {
    summary.notes.push_back("no Pisarenko products in the input: no direct/indirect images");
  }
  if (DrawsEverything(args) && !plan->point_cloud) {
    summary.notes.push_back("no point cloud: give --camera CAPTURE.h5 for the intrinsics");
  }
  if (DrawsEverything(args) && !plan->slices) {
    summary.notes.push_back("no MESE density in the input: no slices, video or streak images");
  }

  DepthPercentiles depth;
  absl::StatusOr<ViewScales> scales = ChooseViewScales(args, source, *plan, hooks, &depth);
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

}  // namespace transient::tools

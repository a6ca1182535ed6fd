// `transient view`: every picture kind from a small synthetic reconstruction file with known
// values, the run-wide colour scale, the streak image, PLY, the video, and bad inputs.
#include "tools/transient/view/view_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>


#include "tools/transient/commands/calibrate_command.h"
#include "tools/transient/commands/moments_command.h"
#include "tools/transient/commands/record_command.h"
#include "tests/tools/image_readers.h"
#include "tests/support/scratch_directory.h"
#include "transient/drivers/simulator.h"
#include "tests/support/video_probe.h"
#include "tests/support/status_matchers.h"
#include "tests/formats/test_files.h"
#include "tests/formats/view_test_files.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/view/pixel_plot.h"
#include "transient/formats/reconstruction_reader.h"

namespace transient::tools {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using testing::ReadPng;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kViewGeometry = testing::kViewGeometry;

TransientFrame ReadFrame(const std::string& path, int64_t index) {
  absl::StatusOr<ReconstructionReader> reader = ReconstructionReader::Open(path);
  EXPECT_THAT(reader.status(), IsOk());
  TransientFrame frame;
  EXPECT_THAT(reader->ReadFrame(index, reader->available(), &frame), IsOk());
  return frame;
}

// The colour of data pixel (x, y) in a rendered figure PNG, read at the centre of its block.
Rgb8 DataPixel(const testing::RawPng& png, const ImageFigure& figure, int x, int y) {
  const cv::Rect area = DataArea(figure);
  const int zoom_x = area.width / figure.geometry.width;
  const int zoom_y = area.height / figure.geometry.height;
  const size_t offset =
      (static_cast<size_t>(area.y + y * zoom_y + zoom_y / 2) * png.width + area.x +
       x * zoom_x + zoom_x / 2) * 3;
  return {png.bytes[offset], png.bytes[offset + 1], png.bytes[offset + 2]};
}

ViewArgs ArgsFor(const ScratchDirectory& dir, const std::string& input) {
  return {.input_path = input, .output_dir = dir.File("out")};
}

TEST(ViewCommand, DrawsEveryPictureKindAtItsExpectedSize) {
  ScratchDirectory dir;
  const std::string input = dir.File("r.h5");
  testing::WriteViewReconstruction(input);
  ViewArgs args = ArgsFor(dir, input);
  args.slices = args.cumulative = args.images = true;
  args.tau_ns = {10.0};  // bin 3 (3.125 ns per bin)
  args.streak_rows = {2};
  args.pixels = {{4, 5}};
  absl::StatusOr<ViewSummary> summary = RunView(args);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_EQ(summary->frames, 2);
  EXPECT_EQ(summary->png_files, 2 * (1 + 1 + 1 + 6 + 1));

  const TransientFrame frame = ReadFrame(input, 1);
  const std::filesystem::path out = dir.path() / "out" / "frame_001";
  const auto expect_size = [&](const std::string& name, const ImageFigure& figure) {
    SCOPED_TRACE(name);
    const testing::RawPng png = ReadPng((out / name).string());
    const cv::Mat rendered = RenderImageFigure(figure);
    EXPECT_EQ(png.width, static_cast<uint32_t>(rendered.cols));
    EXPECT_EQ(png.height, static_cast<uint32_t>(rendered.rows));
    EXPECT_EQ(png.width % 2, 0u);
    EXPECT_EQ(png.height % 2, 0u);
  };
  const ViewScales& scales = summary->scales;
  const ImageFigure slice = SliceFigure(frame, 3, scales.density);
  EXPECT_EQ(DataArea(slice).size(), cv::Size(kViewGeometry.width * 40, kViewGeometry.height * 40));
  expect_size("slices/slice_003.png", slice);
  expect_size("cumulative/slice_003.png", CumulativeFigure(frame, 3, scales.cumulative));
  expect_size("streak_y002.png", StreakFigure(frame, 2, scales.density));
  expect_size("range.png", RangeFigure(frame, scales));
  expect_size("range_pisarenko.png", RangeFigure(frame, scales, true));
  expect_size("amplitude.png", AmplitudeFigure(frame, scales.amplitude));
  expect_size("flags.png", FlagsFigure(frame));
  expect_size("direct.png", DirectFigure(frame, scales.direct_indirect));
  expect_size("indirect.png", IndirectFigure(frame, scales.direct_indirect));
  const testing::RawPng plot = ReadPng((out / "pixel_x004_y005.png").string());
  EXPECT_EQ(plot.width, static_cast<uint32_t>(kPixelPlotWidth));
  EXPECT_EQ(plot.height, static_cast<uint32_t>(kPixelPlotHeight));
}

TEST(ViewCommand, OneDensityScaleColoursEqualValuesEquallyInEveryFrameAndBin) {
  ScratchDirectory dir;
  const std::string input = dir.File("r.h5");
  testing::WriteViewReconstruction(input);
  ViewArgs args = ArgsFor(dir, input);
  args.slices = true;
  absl::StatusOr<ViewSummary> summary = RunView(args);
  ASSERT_THAT(summary.status(), IsOk());

  // The scale is the 99.5th percentile of the density over both frames and all bins.
  std::vector<float> all;
  for (int f = 0; f < testing::kViewFrames; ++f) {
    for (int n = 0; n < testing::kViewBins; ++n) {
      for (int64_t p = 0; p < kViewGeometry.pixel_count(); ++p) {
        all.push_back(testing::KnownDensity(f, n, p));
      }
    }
  }
  EXPECT_DOUBLE_EQ(summary->scales.density, Quantile(all, kScaleQuantile));

  // The front (density 10 + ramp) at column x = bin - frame: frame 0, bin 5 and frame 1, bin 6
  // hold the same value 10.005 at pixel (5, 0).
  const TransientFrame frame0 = ReadFrame(input, 0);
  ASSERT_EQ(testing::KnownDensity(0, 5, 5), testing::KnownDensity(1, 6, 5));
  const ImageFigure figure = SliceFigure(frame0, 5, summary->scales.density);
  const testing::RawPng png0 =
      ReadPng((dir.path() / "out" / "frame_000" / "slices" / "slice_005.png").string());
  const testing::RawPng png1 =
      ReadPng((dir.path() / "out" / "frame_001" / "slices" / "slice_006.png").string());
  const Rgb8 colour0 = DataPixel(png0, figure, 5, 0);
  EXPECT_EQ(colour0, DataPixel(png1, figure, 5, 0));
  EXPECT_EQ(colour0, ColourMap(testing::KnownDensity(0, 5, 5),
                               static_cast<float>(summary->scales.density)));
  // And a lower value elsewhere in the same picture gets another colour.
  EXPECT_NE(colour0, DataPixel(png0, figure, 6, 0));
}

TEST(ViewCommand, StreakImageRowsAreBinsAndColumnsArePixelsOfTheScanline) {
  ScratchDirectory dir;
  const std::string input = dir.File("r.h5");
  testing::WriteViewReconstruction(input);
  const TransientFrame frame = ReadFrame(input, 1);
  constexpr int kRow = 6;
  const std::vector<float> streak = StreakPlane(frame, kRow);
  ASSERT_EQ(streak.size(), static_cast<size_t>(testing::kViewBins * kViewGeometry.width));
  for (int n = 0; n < testing::kViewBins; ++n) {
    for (int x = 0; x < kViewGeometry.width; ++x) {
      ASSERT_EQ(streak[n * kViewGeometry.width + x],
                testing::KnownDensity(1, n, int64_t{kRow} * kViewGeometry.width + x));
    }
  }
  const ImageFigure figure = StreakFigure(frame, kRow, 12.0);
  EXPECT_EQ(figure.geometry,
            (ImageGeometry{.width = kViewGeometry.width, .height = testing::kViewBins}));
  EXPECT_DOUBLE_EQ(figure.y.begin, -50.0 / testing::kViewBins / 2);  // half a bin before 0 ns
  EXPECT_DOUBLE_EQ(figure.y.end, 50.0 - 50.0 / testing::kViewBins / 2);
}

// Reads an ASCII PLY: the header lines, then the vertex lines.
struct AsciiPly {
  std::vector<std::string> header;
  std::vector<std::vector<double>> vertices;
};

AsciiPly ReadAsciiPly(const std::string& path) {
  std::ifstream in(path);
  AsciiPly ply;
  std::string line;
  int64_t count = -1;
  while (std::getline(in, line)) {
    ply.header.push_back(line);
    if (line.rfind("element vertex ", 0) == 0) count = std::stoll(line.substr(15));
    if (line == "end_header") break;
  }
  EXPECT_GE(count, 0) << "no element vertex line";
  for (int64_t i = 0; i < count && std::getline(in, line); ++i) {
    std::istringstream values(line);
    std::vector<double> vertex;
    for (double v; values >> v;) vertex.push_back(v);
    ply.vertices.push_back(vertex);
  }
  EXPECT_FALSE(std::getline(in, line)) << "data after the last vertex";
  return ply;
}

TEST(ViewCommand, PointCloudHasOnePointPerFiniteRangeAlongEachPixelsRay) {
  ScratchDirectory dir;
  const TransientFrame frame = ReadFrame(
      [&] {
        testing::WriteViewReconstruction(dir.File("r.h5"));
        return dir.File("r.h5");
      }(),
      0);
  const PinholeIntrinsics intrinsics{.fx = 10.0, .fy = 12.0, .cx = 5.5, .cy = 3.5};
  const PointCloud cloud = PointsFromRange(frame.geometry, frame.range_m, intrinsics,
                                           std::span<const float>(frame.c0), 200.0f);
  ASSERT_THAT(WritePly(dir.File("p.ply"), cloud, PlyFormat::kAscii, {"test"}), IsOk());
  const AsciiPly ply = ReadAsciiPly(dir.File("p.ply"));
  EXPECT_THAT(std::vector<std::string>(ply.header.begin(), ply.header.begin() + 4),
              ElementsAre("ply", "format ascii 1.0", "comment test",
                          absl::StrCat("element vertex ", kViewGeometry.pixel_count() - 1)));
  EXPECT_THAT(std::vector<std::string>(ply.header.begin() + 4, ply.header.end()),
              ElementsAre("property float x", "property float y", "property float z",
                          "property uchar red", "property uchar green", "property uchar blue",
                          "end_header"));
  ASSERT_EQ(ply.vertices.size(), static_cast<size_t>(kViewGeometry.pixel_count() - 1));

  // Pixel (2, 1) is point 14 (pixel (3, 2), later in the scan, has no range).
  const double range = testing::KnownRange(0, 1 * kViewGeometry.width + 2);
  const double u = (2 - 5.5) / 10.0, v = (1 - 3.5) / 12.0, norm = std::sqrt(u * u + v * v + 1);
  constexpr double kFloatTolerance = 1e-6;  // float32 coordinates of a ~1 m point
  const std::vector<double>& point = ply.vertices[14];
  ASSERT_EQ(point.size(), 6u);
  EXPECT_NEAR(point[0], range * u / norm, kFloatTolerance);
  EXPECT_NEAR(point[1], range * v / norm, kFloatTolerance);
  EXPECT_NEAR(point[2], range / norm, kFloatTolerance);
  const Rgb8 colour = ColourMap(testing::KnownC0(0, 14), 200.0f);
  EXPECT_THAT(std::vector<double>(point.begin() + 3, point.end()),
              ElementsAre(colour.r, colour.g, colour.b));

  // The binary file holds the same header with 15 bytes per coloured vertex.
  ASSERT_THAT(WritePly(dir.File("b.ply"), cloud, PlyFormat::kBinary), IsOk());
  std::ifstream binary(dir.File("b.ply"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(binary)), {});
  const size_t end = bytes.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_THAT(bytes.substr(0, 40), HasSubstr("format binary_little_endian 1.0"));
  EXPECT_EQ(bytes.size() - end - 11, ply.vertices.size() * 15);
  float x14 = 0.0f;
  std::memcpy(&x14, bytes.data() + end + 11 + 14 * 15, 4);
  EXPECT_NEAR(x14, range * u / norm, kFloatTolerance);
}

TEST(ViewCommand, PointCloudTakesTheIntrinsicsOfACaptureFileOfTheSameCamera) {
  ScratchDirectory dir;
  const std::string input = dir.File("r.h5");
  testing::WriteViewReconstruction(input);
  ViewArgs args = ArgsFor(dir, input);
  args.point_cloud = true;
  EXPECT_THAT(RunView(args).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("--point-cloud needs the camera's intrinsics")));
  args.camera_path = dir.File("missing_capture.h5");
  EXPECT_THAT(RunView(args).status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("missing_capture.h5")));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "out"));

  // A simulated camera of the reconstruction's size.
  absl::StatusOr<std::string> uri = SimulatorUri("mirrors", 1, {"width=12", "height=8"});
  ASSERT_THAT(uri.status(), IsOk());
  ASSERT_THAT(RunRecord({.source_uri = *uri, .output_path = dir.File("cap.h5"), .frames = 1})
                  .status(),
              IsOk());
  args.camera_path = dir.File("cap.h5");
  args.ply_format = PlyFormat::kAscii;
  ASSERT_THAT(RunView(args).status(), IsOk());
  const AsciiPly ply = ReadAsciiPly(dir.File("out/frame_001/points.ply"));
  EXPECT_EQ(ply.vertices.size(), static_cast<size_t>(kViewGeometry.pixel_count() - 1));
}

TEST(ViewCommand, PixelPlotDrawsTheDensityCurveAndPisarenkoStems) {
  ScratchDirectory dir;
  const std::string input = dir.File("r.h5");
  testing::WriteViewReconstruction(input);
  const TransientFrame frame = ReadFrame(input, 0);
  const cv::Mat plot = RenderPixelPlot(frame, 4, 5);
  ASSERT_EQ(plot.size(), cv::Size(kPixelPlotWidth, kPixelPlotHeight));
  const auto count = [&](cv::Vec3b colour) {
    int n = 0;
    for (int y = 0; y < plot.rows; ++y) {
      for (int x = 0; x < plot.cols; ++x) n += plot.at<cv::Vec3b>(y, x) == colour;
    }
    return n;
  };
  EXPECT_GT(count(cv::Vec3b(0, 114, 178)), 100);   // the MESE curves
  EXPECT_GT(count(cv::Vec3b(213, 94, 0)), 100);    // the Pisarenko stems and staircase
  EXPECT_GT(count(cv::Vec3b(190, 215, 238)), 100); // the bounds band
}

TEST(ViewCommand, VideoHasOneFramePerFrameAndTimeOfFlight) {
  ScratchDirectory dir;
  const std::string input = dir.File("r.h5");
  testing::WriteViewReconstruction(input);
  ViewArgs args = ArgsFor(dir, input);
  args.video = true;
  args.tau_ns = {0.0, 20.0, 40.0};
  absl::StatusOr<ViewSummary> summary = RunView(args);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_EQ(summary->video_frames, 6);
  absl::StatusOr<::transient::testing::VideoInfo> video =
      ::transient::testing::ProbeVideo(dir.File("out/light.mp4"));
  ASSERT_THAT(video.status(), IsOk());
  EXPECT_EQ(video->frames, 6);
  EXPECT_EQ(video->codec, "h264");
  const TransientFrame frame = ReadFrame(input, 0);
  const cv::Mat figure = RenderImageFigure(SliceFigure(frame, 0, summary->scales.density));
  EXPECT_EQ(cv::Size(video->width, video->height), figure.size());
  // Only the video and the frame directories; no temporary file is left.
  std::vector<std::string> entries;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path() / "out")) {
    entries.push_back(entry.path().filename().string());
  }
  std::sort(entries.begin(), entries.end());
  EXPECT_THAT(entries, ElementsAre("frame_000", "frame_001", "light.mp4"));
}

TEST(ViewCommand, AMomentFileIsReconstructedFirst) {
  ScratchDirectory dir;
  const std::string input = dir.File("m.h5");
  testing::WriteSmallMomentFile(input);  // 2 frames, m = 3, 4x3 px
  ViewArgs args = ArgsFor(dir, input);
  args.images = true;
  args.pixels = {{1, 1}};
  args.frames = {.start = 1, .stop = std::nullopt};
  absl::StatusOr<ViewSummary> summary = RunView(args);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_EQ(summary->input_kind, "moments");
  EXPECT_EQ(summary->frames, 1);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out" / "frame_001" / "range.png"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out" / "frame_001" / "pixel_x001_y001.png"));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "out" / "frame_000"));
}

TEST(ViewCommand, ACaptureFileIsDemodulatedAndGivesItsOwnIntrinsics) {
  ScratchDirectory dir;
  absl::StatusOr<std::string> uri = SimulatorUri("corner", 1, {"width=12", "height=8"});
  ASSERT_THAT(uri.status(), IsOk());
  ASSERT_THAT(RunRecord({.source_uri = *uri, .output_path = dir.File("cap.h5"), .frames = 1})
                  .status(),
              IsOk());
  ViewArgs args = ArgsFor(dir, dir.File("cap.h5"));
  args.point_cloud = true;
  EXPECT_THAT(RunView(args).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("cap.h5: a capture without an embedded calibration: give "
                                 "--calibration FILE")));
  ASSERT_THAT(RunCalibrate({.source_uri = "sim:calibration?width=12&height=8",
                            .output_path = dir.File("cal.h5"),
                            .takes = 2})
                  .status(),
              IsOk());
  args.calibration_path = dir.File("cal.h5");
  absl::StatusOr<ViewSummary> summary = RunView(args);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_EQ(summary->input_kind, "capture");
  EXPECT_EQ(summary->ply_files, 1);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out" / "frame_000" / "points.ply"));
}

TEST(ViewCommand, BadInputsAreNamedAndLeaveNothingBehind) {
  ScratchDirectory dir;
  const std::string input = dir.File("r.h5");
  testing::WriteViewReconstruction(input);
  const std::string calibration_like = dir.File("c.h5");
  testing::WriteViewReconstruction(calibration_like);
  testing::SetStringAttribute(calibration_like, "/", "format", "transient-calibration 1");
  const std::string no_density = dir.File("nd.h5");
  testing::WriteViewReconstruction(no_density);
  testing::DeleteObject(no_density, "/density");
  testing::SetStringAttribute(no_density, "/", "method", "pisarenko");
  testing::DeleteObject(no_density, "/cumulative");

  struct Case {
    const char* name;
    void (*edit)(ViewArgs& args);
    std::string input;
    absl::StatusCode code;
    const char* message;
  };
  const Case cases[] = {
      {"not a file", [](ViewArgs&) {}, dir.File("none.h5"), absl::StatusCode::kNotFound,
       "none.h5: no such file"},
      {"wrong format", [](ViewArgs&) {}, calibration_like, absl::StatusCode::kInvalidArgument,
       "found 'transient-calibration 1'"},
      {"missing dataset", [](ViewArgs& a) { a.slices = true; }, no_density,
       absl::StatusCode::kNotFound, "nd.h5: has no dataset /density, which density slices"},
      {"pixel outside", [](ViewArgs& a) { a.pixels = {{12, 0}}; }, input,
       absl::StatusCode::kOutOfRange, "--pixel = 12,0: outside"},
      {"scanline outside", [](ViewArgs& a) { a.streak_rows = {8}; }, input,
       absl::StatusCode::kOutOfRange, "--streak = 8: scanline outside"},
      {"tau beyond a period", [](ViewArgs& a) { a.tau_ns = {50.0}; }, input,
       absl::StatusCode::kOutOfRange, "--tau = 50 ns: expected 0 <= tau < 50 ns"},
      {"negative tau", [](ViewArgs& a) { a.tau_ns = {-1.0}; }, input,
       absl::StatusCode::kInvalidArgument, "--tau = -1: expected a finite time of flight"},
      {"bad scale", [](ViewArgs& a) { a.density_scale = 0.0; }, input,
       absl::StatusCode::kInvalidArgument, "--scale = 0"},
      {"frames outside", [](ViewArgs& a) { a.frames = {.start = 5}; }, input,
       absl::StatusCode::kOutOfRange, "r.h5"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ViewArgs args = ArgsFor(dir, c.input);
    c.edit(args);
    const absl::Status status = RunView(args).status();
    EXPECT_THAT(status, StatusIs(c.code, HasSubstr(c.message)));
    EXPECT_EQ(ExitCodeFor(status), kExitBadInput);
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "out"));
  }
}

}  // namespace
}  // namespace transient::tools

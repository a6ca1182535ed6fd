// The moment-depth pictures of `transient view` (moment_pictures.h): known answers on a box in
// front of a wall, the defaults, the files they write, and the options they refuse.
#include "tools/transient/view/moment_pictures.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <tuple>
#include <utility>
#include <vector>


#include "absl/strings/str_cat.h"
#include "tests/tools/image_readers.h"
#include "tests/support/scratch_directory.h"
#include "transient/drivers/simulator.h"
#include "tests/support/video_probe.h"
#include "tests/support/status_matchers.h"
#include "tests/formats/view_test_files.h"
#include "tools/transient/commands/calibrate_command.h"
#include "tools/transient/commands/info_command.h"
#include "tools/transient/commands/moments_command.h"
#include "tools/transient/commands/record_command.h"
#include "tools/transient/common/exit_status.h"
#include "transient/formats/reconstruction_reader.h"
#include "tools/transient/view/view_command.h"

namespace transient::tools {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using testing::ReadPng;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

// A box at Z = 2 m (columns 6..29, rows 5..34) in front of a wall at Z = 3 m, seen by a 64x40
// camera; every depth in [1.5, 3.5] m.
constexpr ImageGeometry kGeometry = {.width = 64, .height = 40};
constexpr PinholeIntrinsics kIntrinsics = {.fx = 50.0, .fy = 50.0, .cx = 31.5, .cy = 19.5};
constexpr double kBoxZ = 2.0, kWallZ = 3.0;
constexpr int kBoxX0 = 6, kBoxX1 = 30, kBoxY0 = 5, kBoxY1 = 35;  // half-open
constexpr double kBlurPx = 1.5;                                  // Gaussian radius ceil(4.5) = 5 px

bool InBox(double x, double y) {
  return x >= kBoxX0 - 0.5 && x < kBoxX1 - 0.5 && y >= kBoxY0 - 0.5 && y < kBoxY1 - 0.5;
}

std::vector<float> BoxInFrontOfWall() {
  std::vector<float> depth(static_cast<size_t>(kGeometry.pixel_count()));
  for (int y = 0; y < kGeometry.height; ++y) {
    for (int x = 0; x < kGeometry.width; ++x) {
      depth[y * kGeometry.width + x] = static_cast<float>(InBox(x, y) ? kBoxZ : kWallZ);
    }
  }
  return depth;
}

// A plane at 2.5 m (between box and wall), a sphere whose cap sticks out of the wall, and a
// backdrop at 2.5 m.
MomentPictureOptions BoxOptions() {
  return {.enabled = true,
          .near_m = 1.5,
          .far_m = 3.5,
          .blur_px = {kBlurPx},
          .upscale = 2,
          .plane_depth_m = {2.5, 2.5},
          .sphere_m = {3.3, 0.5, 48.0, 20.0},
          .backdrop_depth_m = {2.5, 2.5}};
}

MomentPictures BoxPictures() {
  absl::StatusOr<MomentSetup> setup = ResolveMomentSetup(BoxOptions(), kGeometry, kIntrinsics, {});
  EXPECT_THAT(setup.status(), IsOk());
  absl::StatusOr<MomentPictures> pictures = MomentPictures::Create(*setup);
  EXPECT_THAT(pictures.status(), IsOk());
  const std::vector<float> c0(static_cast<size_t>(kGeometry.pixel_count()), 1.0f);
  EXPECT_THAT(pictures->SetFrame(0, BoxInFrontOfWall(), c0, 2.0), IsOk());
  return *std::move(pictures);
}

// The 64-bit map's bias (alpha = 6e-5) and 16-bit rounding move a bound by far less than this
// where the whole footprint holds one surface 0.5 m (a quarter of the range) from the fragment.
constexpr float kOneSurfaceTolerance = 0.02f;

// Fragments whose camera position satisfies `where`, and their visibilities.
std::vector<float> VisibilityWhere(const Fragments& fragments, const std::vector<float>& visibility,
                                   bool (*where)(float x, float y)) {
  std::vector<float> selected;
  for (size_t i = 0; i < visibility.size(); ++i) {
    if (std::isnan(fragments.depth_m[i]) || !where(fragments.x[i], fragments.y[i])) continue;
    selected.push_back(visibility[i]);
  }
  return selected;
}

// At least 6 px (the filter radius 5 plus bilinear reach) inside the box, and inside the plane.
bool BehindBoxInterior(float x, float y) {
  return x >= 14.0f && x <= 23.0f && y >= 13.0f && y <= 26.0f;
}
// Over the wall, at least 6 px right of the box.
bool OverWallInterior(float x, float y) {
  return x >= 36.0f && x <= 48.0f && y >= 13.0f && y <= 26.0f;
}
// Within reach of the box's right edge (x = 29.5): the filter radius 5 px, one bilinear tap.
bool NearBoxEdge(float x) { return std::abs(x - 29.5f) <= 6.5f; }

TEST(DepthFromRange, DividesRangeByTheLengthOfThePixelsRay) {
  const ImageGeometry geometry{.width = 3, .height = 2};
  const PinholeIntrinsics intrinsics{.fx = 2.0, .fy = 4.0, .cx = 1.0, .cy = 0.0};
  const std::vector<float> range = {2.0f, 2.0f, 3.0f, NAN, 1.0f, 1.0f};
  const std::vector<float> depth = DepthFromRange(geometry, intrinsics, range);
  ASSERT_EQ(depth.size(), range.size());
  constexpr float kFloat = 1e-6f;
  EXPECT_NEAR(depth[1], 2.0f, kFloat);                            // on the optical axis
  EXPECT_NEAR(depth[0], 2.0f / std::sqrt(1.0f + 0.25f), kFloat);  // (-1/2, 0, 1)
  EXPECT_NEAR(depth[5], 1.0f / std::sqrt(1.0f + 0.25f + 1.0f / 16.0f), kFloat);  // (1/2, 1/4, 1)
  EXPECT_TRUE(std::isnan(depth[3]));
}

TEST(MomentPictures, PlaneIsVisibleOverTheWallAndHiddenBehindTheBoxByEveryTest) {
  const MomentPictures pictures = BoxPictures();
  const Fragments& plane = pictures.fragments(VirtualObject::kPlane);
  for (OcclusionTest test : kOcclusionTests) {
    SCOPED_TRACE(OcclusionTestName(test));
    const std::vector<float> visibility = pictures.Visibility(plane, test, 0);
    const std::vector<float> hidden = VisibilityWhere(plane, visibility, BehindBoxInterior);
    const std::vector<float> visible = VisibilityWhere(plane, visibility, OverWallInterior);
    ASSERT_GT(hidden.size(), 100u);
    ASSERT_GT(visible.size(), 100u);
    EXPECT_LE(*std::max_element(hidden.begin(), hidden.end()), kOneSurfaceTolerance);
    EXPECT_GE(*std::min_element(visible.begin(), visible.end()), 1.0f - kOneSurfaceTolerance);
  }
}

TEST(MomentPictures, HardTestIsZeroOrOneWhileMomentTestsBlendAlongTheSilhouette) {
  const MomentPictures pictures = BoxPictures();
  const Fragments& plane = pictures.fragments(VirtualObject::kPlane);
  const auto intermediate = [&](OcclusionTest test) {
    const std::vector<float> visibility = pictures.Visibility(plane, test, 0);
    int count = 0;
    for (size_t i = 0; i < visibility.size(); ++i) {
      if (std::isnan(visibility[i])) continue;
      EXPECT_GE(visibility[i], 0.0f);
      EXPECT_LE(visibility[i], 1.0f);
      if (visibility[i] > 0.05f && visibility[i] < 0.95f) {
        ++count;
        EXPECT_TRUE(NearBoxEdge(plane.x[i])) << "at " << plane.x[i] << "," << plane.y[i];
      }
    }
    return count;
  };
  EXPECT_EQ(intermediate(OcclusionTest::kHardDepth), 0);
  // The silhouette crosses 14 camera rows of the plane at 2 output pixels per camera pixel;
  // a sigma of 1.5 px spreads it over several columns.
  EXPECT_GT(intermediate(OcclusionTest::kHamburger4), 50);
  EXPECT_GT(intermediate(OcclusionTest::kHausdorff4), 50);
  EXPECT_GT(intermediate(OcclusionTest::kVariance), 50);
}

TEST(MomentPictures, VarianceShadowMapsLeakLightThatHamburgerKeepsOut) {
  // Same biased moments: four moments bound the occluded fraction at least as tightly as two
  // (both sharp lower bounds), so VSM is never less visible; between box and wall, where the
  // footprint mixes both, it leaks.
  const MomentPictures pictures = BoxPictures();
  const Fragments& plane = pictures.fragments(VirtualObject::kPlane);
  const std::vector<float> vsm = pictures.Visibility(plane, OcclusionTest::kVariance, 0);
  const std::vector<float> hamburger = pictures.Visibility(plane, OcclusionTest::kHamburger4, 0);
  constexpr float kFloatPaths = 1e-3f;  // two single-precision evaluations of 16-bit moments
  float most_leaked = 0.0f;
  for (size_t i = 0; i < vsm.size(); ++i) {
    if (std::isnan(vsm[i])) continue;
    EXPECT_GE(vsm[i], hamburger[i] - kFloatPaths) << "at " << plane.x[i] << "," << plane.y[i];
    most_leaked = std::max(most_leaked, vsm[i] - hamburger[i]);
  }
  EXPECT_GT(most_leaked, 0.3f);
}

TEST(MomentPictures, SphereCapInFrontOfTheWallIsVisibleAndItsRimHidden) {
  const MomentPictures pictures = BoxPictures();
  const Fragments& sphere = pictures.fragments(VirtualObject::kSphere);
  const std::vector<float> visibility = pictures.Visibility(sphere, OcclusionTest::kHamburger4, 0);
  int front = 0, behind = 0;
  for (size_t i = 0; i < visibility.size(); ++i) {
    const float z = sphere.depth_m[i];
    if (std::isnan(z)) continue;
    // Fragments 0.1 m (a twentieth of the range) or more from the wall.
    if (z < kWallZ - 0.1) {
      ++front;
      EXPECT_GE(visibility[i], 1.0f - kOneSurfaceTolerance);
    } else if (z > kWallZ + 0.1) {
      ++behind;
      EXPECT_LE(visibility[i], kOneSurfaceTolerance);
    }
  }
  EXPECT_GT(front, 100);
  EXPECT_GT(behind, 20);
}

TEST(MomentPictures, BackdropBetweenBoxAndWallLiesInTheBoxsShadowOnly) {
  const MomentPictures pictures = BoxPictures();
  const Fragments& backdrop = pictures.backdrop();
  for (OcclusionTest test : kOcclusionTests) {
    SCOPED_TRACE(OcclusionTestName(test));
    const std::vector<float> visibility = pictures.Visibility(backdrop, test, 0);
    const std::vector<float> shadowed = VisibilityWhere(backdrop, visibility, BehindBoxInterior);
    const std::vector<float> lit = VisibilityWhere(backdrop, visibility, OverWallInterior);
    ASSERT_GT(shadowed.size(), 50u);
    ASSERT_GT(lit.size(), 50u);
    EXPECT_LE(*std::max_element(shadowed.begin(), shadowed.end()), kOneSurfaceTolerance);
    EXPECT_GE(*std::min_element(lit.begin(), lit.end()), 1.0f - kOneSurfaceTolerance);
  }
}

TEST(MomentSetup, DefaultsFollowTheDepthPercentiles) {
  const MomentPictureOptions options{.enabled = true};
  absl::StatusOr<MomentSetup> setup = ResolveMomentSetup(
      options, kGeometry, kIntrinsics, {.low_m = 2.0, .high_m = 3.0, .top_m = 3.1});
  ASSERT_THAT(setup.status(), IsOk());
  constexpr double kRounding = 1e-12;
  EXPECT_NEAR(setup->normalisation.near_m, 1.7, kRounding);  // 0.85 * 2.0 rounded down
  EXPECT_NEAR(setup->normalisation.far_m, 3.6, kRounding);   // 1.15 * 3.1 = 3.565 rounded up
  EXPECT_NEAR(setup->plane.left_depth_m, 2.4, kRounding);    // d_hi - 2 m, m = 0.3
  EXPECT_NEAR(setup->plane.right_depth_m, 3.3, kRounding);   // d_hi + m
  EXPECT_NEAR(setup->sphere.depth_m, 3.15, kRounding);
  EXPECT_NEAR(setup->sphere.radius_m, 0.3, kRounding);
  EXPECT_NEAR(setup->sphere.column, 31.5, kRounding);
  EXPECT_NEAR(setup->backdrop.left_depth_m, 2.2, kRounding);  // (2 + 3)/2 - m
  EXPECT_NEAR(setup->backdrop.right_depth_m, 3.3, kRounding);
  EXPECT_EQ(setup->blur_px[setup->compare_blur], 2.0);
  EXPECT_FALSE(setup->range_given);
}

TEST(MomentSetup, ObjectsBehindFarOrAnEmptyRangeAreRefusedNamingTheOption) {
  const DepthPercentiles depth{.low_m = 2.0, .high_m = 3.0, .top_m = 3.1};
  MomentPictureOptions options{.enabled = true, .far_m = 3.2};
  EXPECT_THAT(ResolveMomentSetup(options, kGeometry, kIntrinsics, depth).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("--far: the virtual plane (default placement) reaches Z = 3.3 "
                                 "m, behind --far = 3.2 m")));
  options = {.enabled = true, .plane_depth_m = {2.0, 4.0}};
  EXPECT_THAT(ResolveMomentSetup(options, kGeometry, kIntrinsics, depth).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("--plane-depth: the virtual plane (given) reaches Z = 4 m")));
  options = {.enabled = true, .sphere_m = {3.7, 0.1}};
  EXPECT_THAT(ResolveMomentSetup(options, kGeometry, kIntrinsics, depth).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--sphere: the virtual")));
  options = {.enabled = true, .near_m = 3.7};
  EXPECT_THAT(ResolveMomentSetup(options, kGeometry, kIntrinsics, depth).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("--near/--far: depth range 3.7..3.6 m is empty")));
  options = {.enabled = true};
  EXPECT_THAT(ResolveMomentSetup(options, kGeometry, kIntrinsics,
                                 {.low_m = NAN, .high_m = NAN, .top_m = NAN})
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no pixel")));
}

TEST(MomentPictureOptions, EachBadOptionIsNamed) {
  struct Case {
    MomentPictureOptions options;
    const char* message;
  };
  const Case cases[] = {
      {{.enabled = true, .near_m = -1.0}, "--near = -1: expected a finite depth >= 0 m"},
      {{.enabled = true, .far_m = 0.0}, "--far = 0: expected a finite depth > 0 m"},
      {{.enabled = true, .near_m = 3.0, .far_m = 2.0}, "--far = 2: expected far > --near = 3 m"},
      {{.enabled = true, .blur_px = {1.0, 0.0}}, "--blur = 0: expected Gaussian sigmas > 0 px"},
      {{.enabled = true, .blur_px = {NAN}}, "--blur = nan"},
      {{.enabled = true, .blur_px = {}}, "--blur = : expected 1 to 8 sigmas"},
      {{.enabled = true, .upscale = 0}, "--upscale = 0: expected an integer in 1..8"},
      {{.enabled = true, .plane_depth_m = {2.0}}, "--plane-depth = 2: expected two depths"},
      {{.enabled = true, .backdrop_depth_m = {2.0, -1.0}}, "--backdrop-depth = 2,-1"},
      {{.enabled = true, .sphere_m = {0.2, 0.3}}, "--sphere = 0.2,0.3: expected Z,R or Z,R,X,Y"},
      {{.enabled = false, .video = true}, "--moment-video: a moment-depth option"},
      {{.enabled = false, .far_m = 3.0}, "--far: a moment-depth option; give --moment-depth"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    EXPECT_THAT(c.options.Validate(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)));
  }
  EXPECT_THAT(MomentPictureOptions{}.Validate(), IsOk());
  EXPECT_THAT(MomentPictureOptions{.enabled = true}.Validate(), IsOk());
  EXPECT_THAT(CheckMomentOptionsForImage({.enabled = true, .blur_px = {1.0, 2.0}},
                                         {.width = 12, .height = 8}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("--blur = 2: the Gaussian (radius ceil(3 sigma) = 6 px, 13 px "
                                 "wide) is wider than the 12x8 px image")));
}

// The view command on the 12x8 synthetic reconstruction (view_test_files.h), with the
// intrinsics of a simulated camera of that size.
class MomentView : public ::testing::Test {
 protected:
  void SetUp() override {
    testing::WriteViewReconstruction(input());
    absl::StatusOr<std::string> uri = SimulatorUri("mirrors", 1, {"width=12", "height=8"});
    ASSERT_THAT(uri.status(), IsOk());
    ASSERT_THAT(RunRecord({.source_uri = *uri, .output_path = camera(), .frames = 1}).status(),
                IsOk());
  }
  std::string input() const { return dir_.File("r.h5"); }
  std::string camera() const { return dir_.File("cap.h5"); }
  std::filesystem::path out() const { return dir_.path() / "out"; }
  ViewArgs Args() const {
    ViewArgs args{.input_path = input(), .output_dir = out().string(), .camera_path = camera()};
    args.moment = {.enabled = true, .blur_px = {0.5, 1.0}, .upscale = 2};
    return args;
  }

  ScratchDirectory dir_;
};

TEST_F(MomentView, WritesEveryPictureOfEveryFrameAtItsFiguresSize) {
  ViewArgs args = Args();
  args.moment.video = true;
  absl::StatusOr<ViewSummary> summary = RunView(args);
  ASSERT_THAT(summary.status(), IsOk());
  ASSERT_TRUE(summary->moment.has_value());
  constexpr int kPerFrame = 1 + 2 * 4 + 1;  // unfiltered map; 4 per blur; one comparison
  EXPECT_EQ(summary->png_files, testing::kViewFrames * kPerFrame);
  EXPECT_EQ(summary->moment_video_frames, testing::kViewFrames);
  EXPECT_THAT(FormatViewSummary(*summary), HasSubstr("\n  moment depth: depth "));

  const std::filesystem::path dir = out() / "frame_001" / kMomentDirectory;
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  EXPECT_THAT(names, ElementsAre("compare_sigma_1.png", "map_sigma_0.5.png", "map_sigma_1.png",
                                 "map_unfiltered.png", "plane_sigma_0.5.png", "plane_sigma_1.png",
                                 "shadow_sigma_0.5.png", "shadow_sigma_1.png",
                                 "sphere_sigma_0.5.png", "sphere_sigma_1.png"));

  // The same figures, drawn again from the frame: the files decode to their sizes.
  absl::StatusOr<ReconstructionReader> reader = ReconstructionReader::Open(input());
  ASSERT_THAT(reader.status(), IsOk());
  TransientFrame frame;
  ASSERT_THAT(reader->ReadFrame(1, reader->available(), &frame), IsOk());
  absl::StatusOr<MomentPictures> pictures = MomentPictures::Create(*summary->moment);
  ASSERT_THAT(pictures.status(), IsOk());
  const PinholeIntrinsics intrinsics = summary->moment->intrinsics;
  ASSERT_THAT(pictures->SetFrame(1, DepthFromRange(frame.geometry, intrinsics, frame.range_m),
                                 frame.c0, summary->scales.amplitude),
              IsOk());
  const auto expect_size = [&](const std::string& name, const cv::Mat& figure) {
    SCOPED_TRACE(name);
    const testing::RawPng png = ReadPng((dir / name).string());
    EXPECT_EQ(png.width, static_cast<uint32_t>(figure.cols));
    EXPECT_EQ(png.height, static_cast<uint32_t>(figure.rows));
    EXPECT_EQ(png.width % 2, 0u);
    EXPECT_EQ(png.height % 2, 0u);
  };
  expect_size("map_unfiltered.png", RenderImageFigure(pictures->MapFigure(-1)));
  expect_size("map_sigma_1.png", RenderImageFigure(pictures->MapFigure(1)));
  const ImageFigure plane =
      pictures->CompositeFigure(VirtualObject::kPlane, OcclusionTest::kHamburger4, 0);
  EXPECT_EQ(DataArea(plane).size(), cv::Size(24, 16));  // upscale 2, drawn 1:1
  expect_size("plane_sigma_0.5.png", RenderImageFigure(plane));
  expect_size("sphere_sigma_1.png", RenderImageFigure(pictures->CompositeFigure(
                                        VirtualObject::kSphere, OcclusionTest::kHamburger4, 1)));
  expect_size("shadow_sigma_0.5.png", pictures->ShadowFigure(0));
  expect_size("compare_sigma_1.png", pictures->ComparisonFigure());

  absl::StatusOr<::transient::testing::VideoInfo> video =
      ::transient::testing::ProbeVideo((out() / "moment_plane.mp4").string());
  ASSERT_THAT(video.status(), IsOk());
  EXPECT_EQ(video->frames, testing::kViewFrames);
  EXPECT_EQ(cv::Size(video->width, video->height), pictures->VideoFrameFigure().size());
}

TEST_F(MomentView, BadOptionsExitWithTwoBeforeAnythingIsWritten) {
  struct Case {
    const char* name;
    void (*edit)(ViewArgs& args);
    const char* message;
  };
  const Case cases[] = {
      {"no camera", [](ViewArgs& a) { a.camera_path.clear(); },
       "--moment-depth needs the camera's intrinsics"},
      {"near >= far",
       [](ViewArgs& a) {
         a.moment.near_m = 2.0;
         a.moment.far_m = 2.0;
       },
       "--far = 2: expected far > --near = 2 m"},
      {"blur <= 0", [](ViewArgs& a) { a.moment.blur_px = {-1.0}; }, "--blur = -1"},
      {"blur too wide",
       [](ViewArgs& a) {
         a.moment.blur_px = {0.5, 4.0};
       },
       "--blur = 4: the Gaussian"},
      {"plane behind far",
       [](ViewArgs& a) {
         a.moment.far_m = 5.0;
         a.moment.plane_depth_m = {2.0, 6.0};
       },
       "--plane-depth: the virtual plane (given) reaches Z = 6 m, behind --far = 5 m"},
      {"defaults behind far", [](ViewArgs& a) { a.moment.far_m = 1.2; }, "behind --far = 1.2 m"},
      {"video alone",
       [](ViewArgs& a) {
         a.moment.enabled = false;
         a.moment.video = true;
       },
       "--moment-video: a moment-depth option"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ViewArgs args = Args();
    c.edit(args);
    const absl::Status status = RunView(args).status();
    EXPECT_THAT(status, StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)));
    EXPECT_EQ(ExitCodeFor(status), kExitBadInput);
    EXPECT_FALSE(std::filesystem::exists(out()));
  }
}

// The command line maps --near/--far and the moment options (main.cc) and exits 2.
TEST_F(MomentView, CommandLineNamesTheOptionAndExitsWithTwo) {
  const std::string log = dir_.File("stderr");
  const auto run = [&](const std::string& options) {
    const std::string command = absl::StrCat(TRANSIENT_BINARY, " view '", input(), "' --out '",
                                             out().string(), "' --camera '", camera(), "' ",
                                             options, " >/dev/null 2>'", log, "' </dev/null");
    const int status = std::system(command.c_str());
    std::ifstream stream(log);
    return std::pair{WIFEXITED(status) ? WEXITSTATUS(status) : -1,
                     std::string(std::istreambuf_iterator<char>(stream), {})};
  };
  auto [code, err] = run("--moment-depth --near 3 --far 2");
  EXPECT_EQ(code, kExitBadInput);
  EXPECT_THAT(err, HasSubstr("error: --far = 2: expected far > --near = 3 m"));
  std::tie(code, err) = run("--moment-depth --blur 0.5,0");
  EXPECT_EQ(code, kExitBadInput);
  EXPECT_THAT(err, HasSubstr("error: --blur = 0: expected Gaussian sigmas > 0 px"));
  EXPECT_FALSE(std::filesystem::exists(out()));
}

}  // namespace
}  // namespace transient::tools

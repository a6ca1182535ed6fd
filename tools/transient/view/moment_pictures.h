// The moment-depth pictures of `transient view --moment-depth` (issue 7): moment shadow mapping
// (thesis ch. 4) applied to camera depth, drawn as the assignment's report does. The camera's
// depth becomes a filtered 64-bit moment map (MomentDepthMapBuilder); virtual objects placed in
// the camera's view ask it which fraction of each pixel's footprint the real scene covers in
// front of them; and since an AMCW camera's light sits at the camera, the same map is a shadow
// map that casts the real scene's soft shadow onto a virtual backdrop. Hard depth test, VSM,
// Hamburger and Hausdorff 4MSM side by side.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/figure.h"
#include "tools/transient/point_cloud.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moment_depth_map.h"

namespace transient::tools {

// frame_NNN/<kMomentDirectory>/ holds a frame's moment-depth pictures.
inline constexpr char kMomentDirectory[] = "moment_depth";
// The side-by-side comparison uses the --blur value nearest to this (px).
inline constexpr double kCompareBlurPx = 2.0;
inline constexpr int kMaxUpscale = 8;
inline constexpr int kMaxBlurs = 8;

// `transient view` options of the moment-depth pictures. Empty vectors and nullopt mean the
// defaults derived from the depth of the frames drawn (ResolveMomentSetup).
struct MomentPictureOptions {
  bool enabled = false;                         // --moment-depth
  std::optional<double> near_m = std::nullopt;  // --near: depth mapped to z̄ = -1, m
  std::optional<double> far_m = std::nullopt;   // --far: depth mapped to z̄ = +1, m
  // --blur: Gaussian sigmas in pixels of the moment map, one set of pictures each.
  std::vector<double> blur_px = {0.5, 1.0, 2.0, 4.0};
  int upscale = 4;                         // --upscale: output pixels per camera pixel (each axis)
  std::vector<double> plane_depth_m = {};  // --plane-depth LEFT,RIGHT: Z of its edges, m
  // --sphere Z,R[,X,Y]: centre depth and radius, m, and the camera pixel of the centre's ray
  // (default: the image centre).
  std::vector<double> sphere_m = {};
  std::vector<double> backdrop_depth_m = {};  // --backdrop-depth LEFT,RIGHT, m
  bool video = false;  // --moment-video: moment_plane.mp4, hard test vs 4MSM over every frame

  // Each option on its own (InvalidArgument naming the option, its value and the rule): near,
  // far finite and >= 0 (far > near when both are given); every blur finite and > 0, at most
  // kMaxBlurs of them; upscale in 1..kMaxUpscale; two depths > 0 for the plane and the
  // backdrop; a sphere Z,R or Z,R,X,Y with Z > R > 0 (in front of the camera); --moment-video
  // and the placement options only with --moment-depth.
  absl::Status Validate() const;
};

// The checks that need the image size: a blur whose Gaussian (2 ceil(3 sigma) + 1 px wide) is
// wider or taller than the image is InvalidArgument naming --blur, the radius and the size.
absl::Status CheckMomentOptionsForImage(const MomentPictureOptions& options,
                                        ImageGeometry geometry);

// Depth percentiles of the frames drawn, the input of the defaults (metres, optical Z).
struct DepthPercentiles {
  double low_m = 0.0;   // 0.5th percentile: the nearest surfaces
  double high_m = 0.0;  // 95th: the farthest large surface (a wall)
  double top_m = 0.0;   // 99.5th
};

// A vertical rectangle (parallel to the camera's y axis) tilted about it: its left edge lies on
// the ray plane of image column left_column at depth Z = left_depth_m, its right edge on that of
// right_column at Z = right_depth_m; it is `height_fraction` of the view high at its mean depth,
// centred on the image's middle row.
struct VirtualPlane {
  double left_depth_m = 1.0;
  double right_depth_m = 1.0;
  double left_column = 0.0;  // camera pixel coordinates (pixel centres at integers)
  double right_column = 0.0;
  double height_fraction = 0.5;
};
// A sphere whose centre lies on the ray of camera pixel (column, row) at depth Z = depth_m.
struct VirtualSphere {
  double depth_m = 1.0;
  double radius_m = 0.1;
  double column = 0.0;  // camera pixel coordinates (pixel centres at integers)
  double row = 0.0;
};

// Everything the pictures of a run share: the normalisation and the placements resolved from
// the options and the depth percentiles.
struct MomentSetup {
  ImageGeometry geometry = {};
  PinholeIntrinsics intrinsics = {};
  DepthNormalisation normalisation = {};
  bool range_given = false;      // --near and --far both given
  bool placement_given = false;  // every placement option given
  VirtualPlane plane = {};
  VirtualSphere sphere = {};
  VirtualPlane backdrop = {};       // the "light at the camera" backdrop
  double viewpoint_offset_m = 0.0;  // the backdrop's viewer sits at (offset, 0, 0)
  std::vector<double> blur_px = {};
  int compare_blur = 0;  // index into blur_px of the side-by-side comparison
  int upscale = 1;
  DepthPercentiles percentiles = {};

  // Geometry of the rendered pictures: upscale times the camera's.
  ImageGeometry output_geometry() const {
    return {.width = geometry.width * upscale, .height = geometry.height * upscale};
  }
};

// The defaults, from the percentiles d_lo, d_hi, d_top (DepthPercentiles) and the margin
// m = 0.1 d_hi:
// - near = 0.85 d_lo rounded down to 0.1 m (at least 0.1 m), far = 1.15 d_top rounded up to
//   0.1 m: the scene's depths with a margin, and room for the objects below;
// - the plane spans image columns 20 %..80 % of the width and half the height, its left edge at
//   Z = d_hi - 2m and its right edge at d_hi + m, so it cuts through the farthest surface two
//   thirds of the way across and passes behind anything nearer;
// - the sphere, of radius m, has its centre at Z = d_hi + m/2 on the image centre's ray: its
//   front cap sticks out of the farthest surface and its rim is hidden behind it;
// - the backdrop covers 95 % of the view, from Z = (d_lo + d_hi)/2 - m on the left to d_hi + m on
//   the right (behind the nearest objects, then through the farthest surface), seen from a
//   viewpoint displaced sideways by 0.3 times its mean depth.
// Given options replace the defaults one by one. InvalidArgument naming the option when near >=
// far, or when an object reaches behind far (the map knows nothing beyond far: a fragment there
// is hidden by every surface, Hausdorff's bound is 1): the plane's or backdrop's farther edge,
// or the sphere's centre (the depth of its rim).
absl::StatusOr<MomentSetup> ResolveMomentSetup(const MomentPictureOptions& options,
                                               ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                                               const DepthPercentiles& percentiles);

// One line for the summary: "depth 1.6..3.4 m (default), plane Z 2.4..3.3 m, ...".
std::string FormatMomentSetup(const MomentSetup& setup);

// How a virtual fragment is tested against the real scene.
enum class OcclusionTest {
  kHardDepth,   // nearest depth texel: hidden when the real depth is nearer (no filtering)
  kVariance,    // variance shadow maps (assignment), on the filtered moments
  kHamburger4,  // Hamburger 4MSM (thesis alg. 4.2)
  kHausdorff4,  // Hausdorff 4MSM (thesis app. C.2)
};
inline constexpr std::array<OcclusionTest, 4> kOcclusionTests = {
    OcclusionTest::kHardDepth, OcclusionTest::kVariance, OcclusionTest::kHamburger4,
    OcclusionTest::kHausdorff4};
const char* OcclusionTestName(OcclusionTest test);

enum class VirtualObject { kPlane, kSphere };
const char* VirtualObjectName(VirtualObject object);  // "virtual plane", "virtual sphere"

// Virtual fragments at the output resolution (upscale times the camera's), row-major.
struct Fragments {
  ImageGeometry geometry = {};
  std::vector<float> depth_m;  // optical Z of the fragment; NaN = no fragment
  std::vector<float> x, y;     // where it falls in the camera image (pixel coordinates)
  std::vector<Rgb8> colour;    // shaded surface colour (objects; empty for the backdrop)
};

// Ray casting of the objects through every output pixel of the camera's view (pixel centre of
// output pixel (U, V): camera coordinates x = (U + 0.5)/upscale - 0.5, likewise y), and of the
// backdrop from the displaced viewpoint (its fragments carry their projection into the camera).
Fragments RenderPlane(const MomentSetup& setup);
Fragments RenderSphere(const MomentSetup& setup);
Fragments RenderBackdrop(const MomentSetup& setup);

// The moment maps and pictures of one frame. Create once per run, SetFrame per frame.
class MomentPictures {
 public:
  // Builders of the unfiltered and each blurred map (64-bit optimized, thesis eq. 4.4) and the
  // fragments of the objects. InvalidArgument from MomentDepthMapBuilder::Create.
  static absl::StatusOr<MomentPictures> Create(const MomentSetup& setup);

  // The frame's optical depth (NaN = none) and its amplitude c0 (the background, grey over
  // [0, c0_scale]); builds every map. InvalidArgument for planes of the wrong size.
  absl::Status SetFrame(int64_t index, std::span<const float> depth_m, std::span<const float> c0,
                        double c0_scale);

  // Visibility 1 - G of each fragment (NaN where there is none): the hard test on the frame's
  // depth, the others on blur_px[blur]'s map bilinearly interpolated at the fragment, as a
  // renderer sampling the map would, with the 64-bit map's bias (kQuantized16MomentBias).
  std::vector<float> Visibility(const Fragments& fragments, OcclusionTest test, int blur) const;

  // Figures. `blur` -1 is the unfiltered map.
  ImageFigure MapFigure(int blur) const;
  ImageFigure CompositeFigure(VirtualObject object, OcclusionTest test, int blur) const;
  ImageFigure BackdropFigure(OcclusionTest test, int blur) const;
  cv::Mat ComparisonFigure() const;      // plane and sphere rows, four tests, compare blur
  cv::Mat ShadowFigure(int blur) const;  // the backdrop, four tests
  cv::Mat VideoFrameFigure() const;      // the plane: hard test and Hamburger 4MSM

  // Writes the frame's pictures into `dir` (created): map_unfiltered.png, map_sigma_S.png,
  // plane_sigma_S.png, sphere_sigma_S.png, shadow_sigma_S.png for every blur S, and
  // compare_sigma_S.png at the compare blur. Returns the number of PNG files written.
  absl::StatusOr<int> WriteFrame(const std::filesystem::path& dir) const;

  const MomentSetup& setup() const { return setup_; }
  const MomentDepthMap& map(int blur) const { return blur < 0 ? unfiltered_ : maps_[blur]; }
  const Fragments& fragments(VirtualObject object) const {
    return object == VirtualObject::kPlane ? plane_ : sphere_;
  }
  const Fragments& backdrop() const { return backdrop_; }

 private:
  explicit MomentPictures(const MomentSetup& setup) : setup_(setup) {}
  std::string Subtitle(int blur) const;
  std::vector<uint8_t> Composite(const Fragments& object,
                                 const std::vector<float>& visibility) const;

  MomentSetup setup_;
  std::vector<MomentDepthMapBuilder> builders_;  // one per blur
  std::optional<MomentDepthMapBuilder> unfiltered_builder_;
  std::vector<MomentDepthMap> maps_;
  MomentDepthMap unfiltered_;
  std::vector<std::vector<float>> texels_;  // decoded b_1..b_4 of each blurred map, interleaved
  Fragments plane_, sphere_, backdrop_;
  int64_t index_ = 0;
  std::vector<float> depth_m_;
  std::vector<float> grey_;  // background c0 / c0_scale, clamped to [0, 1]; NaN = none
};

}  // namespace transient::tools

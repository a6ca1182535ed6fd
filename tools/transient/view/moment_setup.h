// The options and the setup of `transient view --moment-depth` (moment_pictures.h): the depth
// range mapped to the moment map's [-1, 1], the blurs, and where the virtual plane, sphere and
// backdrop stand, resolved from the options and the depth of the frames drawn.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moment_depth_map.h"

namespace transient::tools {

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

}  // namespace transient::tools

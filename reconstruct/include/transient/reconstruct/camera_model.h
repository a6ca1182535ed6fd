// The camera model every part of the project shares (DESIGN.md, "Units and conventions"): a
// pinhole in the conventions of ROS CameraInfo, the unit ray of a pixel, and range <-> depth.
// `range` is the radial distance along a pixel's ray, `depth` its Z coordinate in the optical
// frame (x right, y down, z forward; ROS REP 118). Pixel (0, 0) is the centre of the top-left
// pixel.
//
// Lens distortion (plumb_bob k1, k2, p1, p2, k3) is carried with the camera so that clients can
// undistort, but every ray here is the undistorted pinhole's: a distorted lens sees pixel (x, y)
// along a slightly different ray, so depth from range and point clouds are off by the
// distortion's angle, most toward the image corners. The simulator's camera has none.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/vec3.h"

namespace transient {

// Pinhole intrinsics in pixels: K = [fx 0 cx; 0 fy cy; 0 0 1].
struct PinholeIntrinsics {
  double fx = 0.0, fy = 0.0;  // focal lengths, pixels
  double cx = 0.0, cy = 0.0;  // principal point, pixels

  // "intrinsics: fx = 0: expected a finite value > 0 (px)": fx, fy finite and > 0; cx, cy
  // finite.
  absl::Status Validate() const;
};

// The unit vector along the ray of pixel (x, y): normalize(((x - cx)/fx, (y - cy)/fy, 1)).
Vec3 PixelRay(const PinholeIntrinsics& intrinsics, double x, double y);

// Depth of every pixel from its range: Z = range * PixelRay(x, y).z. A range that is not finite
// (NaN: no return) gives NaN depth. `range_m` and `depth_m` hold geometry.pixel_count() values
// (asserted); they may be the same span.
void DepthFromRange(ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                    std::span<const float> range_m, std::span<float> depth_m);
// The same into a new plane.
std::vector<float> DepthFromRange(ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                                  std::span<const float> range_m);

// The inverse, range of every pixel from its depth: r = Z / PixelRay(x, y).z = Z * |((x - cx)/fx,
// (y - cy)/fy, 1)|, along the same undistorted pinhole ray (lens distortion not removed, as
// above). A depth that is not finite and > 0 (a depth camera's "no depth": NaN, Inf, 0 or
// negative) gives NaN range. Same sizes and aliasing as DepthFromRange.
void RangeFromDepth(ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                    std::span<const float> depth_m, std::span<float> range_m);

// A sensor as a source describes it: its image, pinhole and lens, name and frame period.
struct CameraInfo {
  ImageGeometry geometry;
  PinholeIntrinsics intrinsics;
  std::array<double, 5> distortion{};  // k1, k2, p1, p2, k3 (plumb_bob); not applied, see above
  std::string model;                   // e.g. "transient simulator (pmd PhotonICs 19k-S3 like)"
  double frame_period_s = 0.0;         // time between the starts of two raw frames; 0 = unknown
};

}  // namespace transient

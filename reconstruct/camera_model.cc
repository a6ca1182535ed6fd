// Pinhole rays and depth from range.
#include "transient/reconstruct/camera_model.h"

#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"

namespace transient {

absl::Status PinholeIntrinsics::Validate() const {
  for (auto [name, value] : {std::pair{"fx", fx}, std::pair{"fy", fy}}) {
    if (!(std::isfinite(value) && value > 0.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("intrinsics: ", name, " = ", value, ": expected a finite value > 0 (px)"));
    }
  }
  for (auto [name, value] : {std::pair{"cx", cx}, std::pair{"cy", cy}}) {
    if (!std::isfinite(value)) {
      return absl::InvalidArgumentError(
          absl::StrCat("intrinsics: ", name, " = ", value, ": expected a finite value (px)"));
    }
  }
  return absl::OkStatus();
}

Vec3 PixelRay(const PinholeIntrinsics& intrinsics, double x, double y) {
  return Vec3{(x - intrinsics.cx) / intrinsics.fx, (y - intrinsics.cy) / intrinsics.fy, 1.0}
      .normalized();
}

void DepthFromRange(ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                    std::span<const float> range_m, std::span<float> depth_m) {
  assert(static_cast<int64_t>(range_m.size()) == geometry.pixel_count());
  assert(depth_m.size() == range_m.size());
  for (int y = 0; y < geometry.height; ++y) {
    for (int x = 0; x < geometry.width; ++x) {
      const size_t p = static_cast<size_t>(y) * geometry.width + x;
      const float range = range_m[p];
      depth_m[p] = std::isfinite(range)
                       ? static_cast<float>(range * PixelRay(intrinsics, x, y).z)
                       : std::numeric_limits<float>::quiet_NaN();
    }
  }
}

void RangeFromDepth(ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                    std::span<const float> depth_m, std::span<float> range_m) {
  assert(static_cast<int64_t>(depth_m.size()) == geometry.pixel_count());
  assert(range_m.size() == depth_m.size());
  for (int y = 0; y < geometry.height; ++y) {
    for (int x = 0; x < geometry.width; ++x) {
      const size_t p = static_cast<size_t>(y) * geometry.width + x;
      const float depth = depth_m[p];
      range_m[p] = std::isfinite(depth) && depth > 0.0f
                       ? static_cast<float>(depth / PixelRay(intrinsics, x, y).z)
                       : std::numeric_limits<float>::quiet_NaN();
    }
  }
}

std::vector<float> DepthFromRange(ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                                  std::span<const float> range_m) {
  std::vector<float> depth(range_m.size());
  DepthFromRange(geometry, intrinsics, range_m, depth);
  return depth;
}

}  // namespace transient

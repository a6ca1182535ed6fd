// Range <-> depth along the pinhole ray: RangeFromDepth inverts DepthFromRange, the principal
// point's range is its depth, and a pixel without depth has no range.
#include "transient/reconstruct/camera_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace transient {
namespace {

constexpr ImageGeometry kGeometry{.width = 7, .height = 5};
// float round trips of a division and a multiplication by the same ray factor (<= 1.2 here).
constexpr double kRayFloatRelative = 4e-7;

PinholeIntrinsics Intrinsics() { return {.fx = 4.0, .fy = 5.0, .cx = 3.0, .cy = 2.0}; }

TEST(RangeFromDepth, InvertsDepthFromRange) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<float> uniform(0.2f, 9.0f);
  std::vector<float> range(static_cast<size_t>(kGeometry.pixel_count()));
  for (float& r : range) r = uniform(rng);
  const std::vector<float> depth = DepthFromRange(kGeometry, Intrinsics(), range);
  std::vector<float> back(range.size());
  RangeFromDepth(kGeometry, Intrinsics(), depth, back);
  for (size_t p = 0; p < range.size(); ++p) {
    EXPECT_NEAR(back[p], range[p], kRayFloatRelative * range[p]) << p;
    EXPECT_LE(depth[p], range[p]) << "depth is range times cos of the ray's angle";
  }
}

TEST(RangeFromDepth, IsDepthTimesTheLengthOfTheRayThroughZEqualsOne) {
  std::vector<float> depth(static_cast<size_t>(kGeometry.pixel_count()), 2.0f);
  std::vector<float> range(depth.size());
  RangeFromDepth(kGeometry, Intrinsics(), depth, range);
  // The principal point (3, 2): straight ahead.
  EXPECT_FLOAT_EQ(range[2 * 7 + 3], 2.0f);
  // Pixel (0, 0): ray (-3/4, -2/5, 1).
  EXPECT_NEAR(range[0], 2.0 * std::sqrt(0.75 * 0.75 + 0.4 * 0.4 + 1.0), kRayFloatRelative * 2.5);
}

TEST(RangeFromDepth, APixelWithoutDepthHasNoRange) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> depth(static_cast<size_t>(kGeometry.pixel_count()), 1.0f);
  depth[0] = nan;
  depth[1] = inf;
  depth[2] = 0.0f;  // a depth camera's 16-bit "no depth"
  depth[3] = -1.0f;
  RangeFromDepth(kGeometry, Intrinsics(), depth, depth);  // in place
  for (int p = 0; p < 4; ++p) EXPECT_TRUE(std::isnan(depth[p])) << p;
  EXPECT_TRUE(std::isfinite(depth[4]));
}

}  // namespace
}  // namespace transient

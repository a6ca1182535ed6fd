#include "transient/openni2/oni_frames.h"

#include <cmath>
#include <limits>
#include <numeric>

#include "gtest/gtest.h"

namespace transient::openni2 {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(OniFrames, DepthCountsRoundToTheUnitAndZeroMeansNone) {
  EXPECT_EQ(DepthCount(1.2344f, DepthUnit::kMillimetre, 7000), 1234);
  EXPECT_EQ(DepthCount(1.2346f, DepthUnit::kMillimetre, 7000), 1235);
  EXPECT_EQ(DepthCount(1.23456f, DepthUnit::kHundredMicrometre, 65534), 12346);
  EXPECT_EQ(DepthCount(kNaN, DepthUnit::kMillimetre, 7000), 0);
  EXPECT_EQ(DepthCount(std::numeric_limits<float>::infinity(), DepthUnit::kMillimetre, 7000), 0);
  EXPECT_EQ(DepthCount(-1.0f, DepthUnit::kMillimetre, 7000), 0);
  EXPECT_EQ(DepthCount(0.0004f, DepthUnit::kMillimetre, 7000), 0) << "rounds to nothing";
  // Beyond the maximum: invalid, not clamped (a recording's codec is bounded by MAX_VALUE).
  EXPECT_EQ(DepthCount(7.0f, DepthUnit::kMillimetre, 7000), 7000);
  EXPECT_EQ(DepthCount(7.001f, DepthUnit::kMillimetre, 7000), 0);
  EXPECT_EQ(DepthCount(7.0f, DepthUnit::kHundredMicrometre, 65534), 0) << "past 6.5534 m";
}

TEST(OniFrames, TheMaximumCoversTheCamerasDepthAndIsNeverFfff) {
  EXPECT_EQ(MaxDepthCount(6.5164, DepthUnit::kMillimetre), 6517);
  EXPECT_EQ(MaxDepthCount(7.5, DepthUnit::kMillimetre), 7500);
  EXPECT_EQ(MaxDepthCount(7.5, DepthUnit::kHundredMicrometre), 65534);
  EXPECT_EQ(MaxDepthCount(100.0, DepthUnit::kMillimetre), 65534);
  EXPECT_EQ(MaxDepthCount(0.0, DepthUnit::kMillimetre), 65534);
  EXPECT_EQ(MaxDepthCount(std::nan(""), DepthUnit::kMillimetre), 65534);
}

TEST(OniFrames, DepthMetresInvertsTheCounts) {
  EXPECT_TRUE(std::isnan(DepthMetres(0, DepthUnit::kMillimetre)));
  EXPECT_FLOAT_EQ(DepthMetres(1234, DepthUnit::kMillimetre), 1.234f);
  EXPECT_FLOAT_EQ(DepthMetres(12345, DepthUnit::kHundredMicrometre), 1.2345f);
}

TEST(OniFrames, IrCountsAreScaledRoundedAndClamped) {
  EXPECT_EQ(IrCount(12.4f, 1.0), 12);
  EXPECT_EQ(IrCount(12.4f, 10.0), 124);
  EXPECT_EQ(IrCount(1e6f, 1.0), 65535);
  EXPECT_EQ(IrCount(-3.0f, 1.0), 0);
  EXPECT_EQ(IrCount(kNaN, 1.0), 0);
}

TEST(OniFrames, GreyLevelsAreAnEighthOfTheIrCounts) {
  EXPECT_EQ(GreyLevel(0.0f, 1.0), 0);
  EXPECT_EQ(GreyLevel(8.0f, 1.0), 1);
  EXPECT_EQ(GreyLevel(800.0f, 1.0), 100);
  EXPECT_EQ(GreyLevel(80.0f, 10.0), 100);
  EXPECT_EQ(GreyLevel(2040.0f, 1.0), 255);
  EXPECT_EQ(GreyLevel(1e6f, 1.0), 255);
  EXPECT_EQ(GreyLevel(kNaN, 1.0), 0);
}

CameraInfo Sensor(int width, int height, double f, double cx, double cy) {
  CameraInfo sensor;
  sensor.geometry = {.width = width, .height = height};
  sensor.intrinsics = {.fx = f, .fy = f, .cx = cx, .cy = cy};
  return sensor;
}

TEST(OniFrames, AnIdealSensorIsItsOwnVirtualCamera) {
  const CameraInfo sensor = Sensor(80, 60, 70.0, 39.5, 29.5);
  const VirtualCamera camera = VirtualCameraFor(sensor, 80, 60);
  EXPECT_DOUBLE_EQ(camera.focal_px, 70.0);
  EXPECT_DOUBLE_EQ(camera.HorizontalFov(), 2 * std::atan(80 / 140.0));
  EXPECT_DOUBLE_EQ(camera.VerticalFov(), 2 * std::atan(60 / 140.0));
  std::vector<int32_t> identity(80 * 60);
  std::iota(identity.begin(), identity.end(), 0);
  EXPECT_EQ(ResampleMap(sensor, camera), identity);
}

TEST(OniFrames, AnotherSizeKeepsTheHorizontalFieldOfViewAndCentresTheRays) {
  // An off-centre principal point: the virtual camera's centre ray still hits it.
  const CameraInfo sensor = Sensor(100, 50, 80.0, 52.0, 20.0);
  const VirtualCamera camera = VirtualCameraFor(sensor, 200, 160);
  EXPECT_DOUBLE_EQ(camera.focal_px, 160.0);
  EXPECT_DOUBLE_EQ(camera.HorizontalFov(), 2 * std::atan(100 / 160.0));
  const std::vector<int32_t> map = ResampleMap(sensor, camera);
  ASSERT_EQ(map.size(), 200u * 160u);
  // Pixel (u, v) looks along ((u - 99.5)/160, (v - 79.5)/160); the sensor sees that at
  // (80 x + 52, 80 y + 20), rounded.
  const auto at = [&](int u, int v) { return map[static_cast<size_t>(v) * 200 + u]; };
  EXPECT_EQ(at(100, 80), 20 * 100 + 52);            // (52.25, 20.25)
  EXPECT_EQ(at(0, 80), 20 * 100 + 2);               // (2.25, 20.25)
  EXPECT_EQ(at(100, 120), 40 * 100 + 52);           // (52.25, 40.25)
  EXPECT_EQ(at(199, 79), -1) << "column 101.75 -> 102: right of the sensor";
  EXPECT_EQ(at(100, 0), -1) << "row -19.75: above the sensor";
  EXPECT_EQ(at(100, 159), -1) << "row 59.75 -> 60: below the sensor";
}

}  // namespace
}  // namespace transient::openni2

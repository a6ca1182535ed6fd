#include "transient/openni2/oni_frames.h"

#include <algorithm>
#include <cmath>

namespace transient::openni2 {
namespace {

// Never 0xFFFF (see the header).
constexpr double kLargestCount = 65534.0;

}  // namespace

double MetresPerCount(DepthUnit unit) {
  return unit == DepthUnit::kMillimetre ? 1e-3 : 1e-4;
}

uint16_t MaxDepthCount(double max_depth_m, DepthUnit unit) {
  if (!(std::isfinite(max_depth_m) && max_depth_m > 0.0)) return static_cast<uint16_t>(kLargestCount);
  const double counts = std::ceil(max_depth_m / MetresPerCount(unit) - 1e-9);
  return static_cast<uint16_t>(std::clamp(counts, 1.0, kLargestCount));
}

uint16_t DepthCount(float z_m, DepthUnit unit, uint16_t max_count) {
  // In double, as the daemon's own UINT16_MM encoding rounds (wire/image_codec.cc), so that
  // both give the same millimetres for the same float.
  const double count = std::round(static_cast<double>(z_m) / MetresPerCount(unit));
  if (!(count >= 1.0 && count <= max_count)) return 0;  // NaN fails too
  return static_cast<uint16_t>(count);
}

float DepthMetres(uint16_t count, DepthUnit unit) {
  if (count == 0) return std::nanf("");
  return static_cast<float>(count * MetresPerCount(unit));
}

uint16_t IrCount(float amplitude, double scale) {
  const double count = std::round(static_cast<double>(amplitude) * scale);
  if (!(count > 0.0)) return 0;  // NaN too
  return static_cast<uint16_t>(std::min(count, 65535.0));
}

uint8_t GreyLevel(float amplitude, double scale) {
  return static_cast<uint8_t>(std::min<int>(255, (IrCount(amplitude, scale) + 4) / 8));
}

double VirtualCamera::HorizontalFov() const { return 2.0 * std::atan(width / (2.0 * focal_px)); }
double VirtualCamera::VerticalFov() const { return 2.0 * std::atan(height / (2.0 * focal_px)); }

VirtualCamera VirtualCameraFor(const CameraInfo& sensor, int width, int height) {
  return {.width = width,
          .height = height,
          .focal_px = sensor.intrinsics.fx * width / sensor.geometry.width};
}

std::vector<int32_t> ResampleMap(const CameraInfo& sensor, const VirtualCamera& camera) {
  const PinholeIntrinsics& k = sensor.intrinsics;
  const int sensor_width = sensor.geometry.width, sensor_height = sensor.geometry.height;
  std::vector<int32_t> map(static_cast<size_t>(camera.width) * camera.height, -1);
  for (int v = 0; v < camera.height; ++v) {
    const double y = (v - camera.cy()) / camera.focal_px;
    const long row = std::lround(k.fy * y + k.cy);
    if (row < 0 || row >= sensor_height) continue;
    for (int u = 0; u < camera.width; ++u) {
      const double x = (u - camera.cx()) / camera.focal_px;
      const long col = std::lround(k.fx * x + k.cx);
      if (col < 0 || col >= sensor_width) continue;
      map[static_cast<size_t>(v) * camera.width + u] =
          static_cast<int32_t>(row * sensor_width + col);
    }
  }
  return map;
}

}  // namespace transient::openni2

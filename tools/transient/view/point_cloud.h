// Point clouds from range images and pinhole intrinsics (thesis fig. 8.13), written as PLY
// (Stanford polygon format: ASCII or binary little-endian, vertices only), which MeshLab,
// Open3D, CloudCompare and Blender open.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "tools/transient/common/image_writers.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/image.h"

namespace transient::tools {

struct PointCloud {
  std::vector<std::array<float, 3>> points;  // metres, optical frame of the camera
  std::vector<Rgb8> colours;                 // empty or one per point
  std::vector<int64_t> pixels;               // the pixel (y * width + x) of each point
};

// One point range * PixelRay(intrinsics, x, y) per pixel with a finite range (range is the radial distance
// along the ray, docs/reconstruction.md, units.h); NaN and infinite ranges are skipped. With `amplitude` (one
// value per pixel) each point is coloured ColourMap(amplitude, amplitude_scale).
PointCloud PointsFromRange(ImageGeometry geometry, std::span<const float> range_m,
                           const PinholeIntrinsics& intrinsics,
                           std::optional<std::span<const float>> amplitude = std::nullopt,
                           float amplitude_scale = 1.0f);

enum class PlyFormat { kAscii, kBinary };

// Writes `cloud` as PLY: "element vertex N" with float x, y, z and, when coloured, uchar red,
// green, blue; `comments` become header comment lines. Written under a temporary name and
// renamed, so a failed write leaves no file. Errors name `path`.
absl::Status WritePly(const std::string& path, const PointCloud& cloud, PlyFormat format,
                      const std::vector<std::string>& comments = {});

}  // namespace transient::tools

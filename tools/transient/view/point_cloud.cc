// Back-projection of range images along pixel rays and the PLY writer.
#include "tools/transient/view/point_cloud.h"

#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/formats/atomic_output.h"

namespace transient::tools {

PointCloud PointsFromRange(ImageGeometry geometry, std::span<const float> range_m,
                           const PinholeIntrinsics& intrinsics,
                           std::optional<std::span<const float>> amplitude,
                           float amplitude_scale) {
  PointCloud cloud;
  for (int y = 0; y < geometry.height; ++y) {
    for (int x = 0; x < geometry.width; ++x) {
      const int64_t p = int64_t{y} * geometry.width + x;
      const float range = range_m[p];
      if (!std::isfinite(range)) continue;
      const Vec3 ray = PixelRay(intrinsics, x, y);
      cloud.points.push_back({static_cast<float>(range * ray.x), static_cast<float>(range * ray.y),
                              static_cast<float>(range * ray.z)});
      cloud.pixels.push_back(p);
      if (amplitude.has_value()) cloud.colours.push_back(ColourMap((*amplitude)[p], amplitude_scale));
    }
  }
  return cloud;
}

namespace {

// PLY binary_little_endian stores IEEE floats in little-endian byte order.
void AppendFloatLittleEndian(std::string& out, float value) {
  uint32_t bits = std::bit_cast<uint32_t>(value);
  if constexpr (std::endian::native == std::endian::big) bits = __builtin_bswap32(bits);
  char bytes[4];
  std::memcpy(bytes, &bits, 4);
  out.append(bytes, 4);
}

}  // namespace

absl::Status WritePly(const std::string& path, const PointCloud& cloud, PlyFormat format,
                      const std::vector<std::string>& comments) {
  const bool coloured = !cloud.colours.empty();
  if (coloured && cloud.colours.size() != cloud.points.size()) {
    return absl::InternalError(absl::StrCat(path, ": ", cloud.colours.size(), " colours for ",
                                            cloud.points.size(), " points"));
  }
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path);
  if (!output.ok()) return output.status();

  std::string text = absl::StrCat(
      "ply\nformat ", format == PlyFormat::kAscii ? "ascii" : "binary_little_endian", " 1.0\n");
  for (const std::string& comment : comments) absl::StrAppend(&text, "comment ", comment, "\n");
  absl::StrAppend(&text, "element vertex ", cloud.points.size(),
                  "\nproperty float x\nproperty float y\nproperty float z\n");
  if (coloured) {
    absl::StrAppend(&text, "property uchar red\nproperty uchar green\nproperty uchar blue\n");
  }
  absl::StrAppend(&text, "end_header\n");
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const std::array<float, 3>& point = cloud.points[i];
    if (format == PlyFormat::kAscii) {
      // %.9g round-trips a float exactly.
      absl::StrAppendFormat(&text, "%.9g %.9g %.9g", point[0], point[1], point[2]);
      if (coloured) {
        absl::StrAppendFormat(&text, " %d %d %d", cloud.colours[i].r, cloud.colours[i].g,
                              cloud.colours[i].b);
      }
      text.push_back('\n');
    } else {
      for (float value : point) AppendFloatLittleEndian(text, value);
      if (coloured) {
        text.push_back(static_cast<char>(cloud.colours[i].r));
        text.push_back(static_cast<char>(cloud.colours[i].g));
        text.push_back(static_cast<char>(cloud.colours[i].b));
      }
    }
  }

  std::FILE* file = std::fopen(output->temporary_path().c_str(), "wb");
  if (file == nullptr) {
    return absl::ErrnoToStatus(errno, absl::StrCat(path, ": cannot create the file"));
  }
  const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
  const int write_errno = errno;
  if (std::fclose(file) != 0 || !written) {
    return absl::ErrnoToStatus(written ? errno : write_errno,
                               absl::StrCat(path, ": writing the file failed"));
  }
  return output->Commit();
}

}  // namespace transient::tools

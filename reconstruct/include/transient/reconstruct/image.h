// Planar (structure-of-arrays) moment images: the input of the image-level reconstruction API.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/status.h"

namespace transient {

// Width and height of a sensor image in pixels. Planes are row-major with stride == width.
struct ImageGeometry {
  int width = 0;
  int height = 0;

  int64_t pixel_count() const { return int64_t{width} * height; }
  friend bool operator==(const ImageGeometry&, const ImageGeometry&) = default;
};

// Trigonometric moments c_0..c_m of every pixel of one frame, as float32 planes.
// Plane j (0 <= j <= m) of `real` and `imag` holds Re c_j and Im c_j of all pixels at offset
// j * pixel_count(). c_0 is real: imag plane 0 is ignored. Units are those of the sensor
// (arbitrary but linear in light); the phase origin is the calibrated zero of thesis §8.3.2.
struct MomentImage {
  ImageGeometry geometry;
  int order = 0;               // m, 1 <= m <= kMaxOrder
  std::vector<float> real;     // (m+1) * pixel_count()
  std::vector<float> imag;     // (m+1) * pixel_count()
  std::vector<uint8_t> valid;  // empty (all valid) or pixel_count(); 0 = invalid pixel

  MomentImage() = default;
  MomentImage(ImageGeometry g, int m);

  // Checks order, geometry and buffer sizes; the message names the violated constraint.
  absl::Status Validate() const;

  float* real_plane(int j) { return real.data() + j * geometry.pixel_count(); }
  float* imag_plane(int j) { return imag.data() + j * geometry.pixel_count(); }
  const float* real_plane(int j) const { return real.data() + j * geometry.pixel_count(); }
  const float* imag_plane(int j) const { return imag.data() + j * geometry.pixel_count(); }
};

}  // namespace transient

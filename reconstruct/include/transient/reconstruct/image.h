// Planar (structure-of-arrays) moment images: the input of the image-level reconstruction API.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "absl/status/status.h"

namespace transient {

// Width and height of a sensor image in pixels. Planes are row-major with stride == width.
// NaN marks a value that is not there (an invalid pixel, a missing product) in every image.
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

struct ImageGeometry {
  int width = 0;
  int height = 0;

  int64_t pixel_count() const { return int64_t{width} * height; }
  friend bool operator==(const ImageGeometry&, const ImageGeometry&) = default;
};

// Bits of the per-pixel flags planes of moment images and products. A pixel with
// kFlagInvalidInput has no products (NaN).
enum PixelFlag : uint8_t {
  kFlagBiased = 1 << 0,        // biasing changed the moments (an estimated c_0 alone does not)
  kFlagInvalidInput = 1 << 1,  // NaN/Inf, c_0 <= 0, marked invalid, or not repairable
  kFlagNoReturn = 1 << 2,      // no peak / return above the relative threshold
  kFlagSaturated = 1 << 3,     // a raw frame of this pixel was saturated (also invalid)
  kFlagOutlierFilled = 1 << 4, // filled from the previous frame after an outlier capture
  // Phase unwrapping (phase_unwrapping.h), on cameras whose harmonics are not 1..m:
  kFlagAmbiguous = 1 << 5,     // two distances explain the phases equally well: no range
  kFlagLowAmplitude = 1 << 6,  // too little modulated light: no range
};
// The bits a MomentImage carries into the products of its pixels.
inline constexpr uint8_t kMomentImageFlags = kFlagSaturated | kFlagOutlierFilled;

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
  std::vector<uint8_t> flags;  // empty or pixel_count(); kMomentImageFlags bits, copied into the
                               // products' flags (the other bits are ignored)

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

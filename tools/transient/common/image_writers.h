// Image files for people and common tools to open: 16-bit and 8-bit grayscale PNG (depth in
// millimetres, flag bits), 8-bit RGB PNG (colour-mapped slices), single-channel 32-bit float
// TIFF (range in metres with NaN kept), and the perceptual colour map of the RGB images.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "transient/reconstruct/image.h"

namespace transient::tools {

// All writers take row-major planes of geometry.pixel_count() values (three bytes per pixel,
// R G B, for RGB), replace `path` if it exists, and return InvalidArgument for an empty
// geometry or a plane of the wrong size, and an error naming `path` when the file cannot be
// created (the errno text: missing directory, permission) or written (disk full); a file that
// failed half-way is removed.

// 16-bit grayscale PNG; the samples are stored big-endian, as PNG requires.
absl::Status WritePng16(const std::string& path, ImageGeometry geometry,
                        std::span<const uint16_t> pixels);
// 8-bit grayscale PNG.
absl::Status WritePng8(const std::string& path, ImageGeometry geometry,
                       std::span<const uint8_t> pixels);
// 8-bit RGB PNG.
absl::Status WritePngRgb8(const std::string& path, ImageGeometry geometry,
                          std::span<const uint8_t> rgb);
// Uncompressed single-channel IEEE float TIFF (SAMPLEFORMAT_IEEEFP, 32 bits, MINISBLACK);
// every value, NaN and infinities included, is stored as it is.
absl::Status WriteTiffFloat(const std::string& path, ImageGeometry geometry,
                            std::span<const float> pixels);

// Millimetres of a length in metres as REP 118 16UC1 depth: round(1000 * metres), and 0 (invalid)
// for NaN, values <= 0 and values that round above 65535 mm.
uint16_t MetresToMillimetres(float metres);

struct Rgb8 {
  uint8_t r = 0;
  uint8_t g = 0;
  uint8_t b = 0;
  friend bool operator==(const Rgb8&, const Rgb8&) = default;
};

// Grey of pixels without a value (NaN) in colour-mapped images: it is not a colour of the map.
inline constexpr Rgb8 kNoValueGrey = {128, 128, 128};

// A perceptual, sequential colour map after matplotlib's "inferno" (van der Walt & Smith,
// 2015), approximated by linear interpolation in sRGB between nine control points read off the
// published map: near black at 0 through purple and orange to pale yellow at 1, with luminance
// rising strictly, so that it stays readable in grey. t = value / scale, clamped to [0, 1]
// (-inf gives 0, +inf gives 1); NaN gives kNoValueGrey. `scale` must be > 0 and finite
// (asserted).
Rgb8 ColourMap(float value, float scale);

// ColourMap of every value of a plane: three bytes per value.
std::vector<uint8_t> ColourMapPlane(std::span<const float> values, float scale);

}  // namespace transient::tools

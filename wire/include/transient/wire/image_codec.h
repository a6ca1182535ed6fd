// Images on the wire: a full-sensor plane of a product, cropped to the subscriber's region of
// interest, in the encoding it asked for (32FC1 float, 16FC1 half float, 16UC1 millimetres),
// optionally zstd-compressed; and the inverse for clients. Layout: row-major, little endian,
// step = width * bytes per pixel (DESIGN.md, "Units and conventions"; ROS REP 118 for depth).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/v1/transient.pb.h"

namespace transient::wire {

// A region of interest resolved against a sensor: non-empty and inside it.
struct PixelRect {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;

  int64_t pixel_count() const { return int64_t{width} * height; }
  friend bool operator==(const PixelRect&, const PixelRect&) = default;
};

// width = height = 0 is the whole sensor. InvalidArgument naming "roi" and the sensor size
// when the rectangle is empty in one dimension only or reaches outside the sensor.
absl::StatusOr<PixelRect> ResolveRoi(const v1::Roi& roi, ImageGeometry sensor);

// Whether `product` can be sent in `encoding`, by its EncodingRule (product_registry.h):
// UINT16_MM only for RANGE and DEPTH (lengths); FLAGS (always 8UC1) and MOMENT_DEPTH (16UC4 or
// 32FC4) accept any known encoding request and ignore it. InvalidArgument naming the product
// and the encoding otherwise.
absl::Status CheckEncoding(v1::Product product, v1::Encoding encoding);

// The ROS encoding string of a float plane sent as `encoding`: 32FC1, 16FC1 or 16UC1.
const char* EncodingName(v1::Encoding encoding);

// Crops `plane` (geometry `sensor`, row-major, one float per pixel in the product's SI unit)
// to `rect` and fills out->width/height/encoding/step/data/compression. Float encodings keep
// NaN; UINT16_MM writes round(1000 * value) with 0 for NaN, <= 0 and values above 65.535 m
// (REP 118: 0 is invalid). The caller sets name, product and unit. `plane` must hold
// sensor.pixel_count() values and `rect` lie inside `sensor` (asserted).
absl::Status EncodeFloatPlane(std::span<const float> plane, ImageGeometry sensor,
                              const PixelRect& rect, v1::Encoding encoding,
                              v1::Compression compression, v1::Image* out);

// The same for a byte plane (FLAGS): 8UC1.
absl::Status EncodeBytePlane(std::span<const uint8_t> plane, ImageGeometry sensor,
                             const PixelRect& rect, v1::Compression compression, v1::Image* out);

// Client side: the image's values as floats in the product's SI unit (16UC1 millimetres become
// metres, 0 becomes NaN; 8UC1 bytes become 0..255), ImageChannels(image) values per pixel,
// interleaved (16UC4 gives the four codes 0..65535 of each pixel, 32FC4 its four floats).
// DataLoss naming the image when the data does not fit width, height, step and encoding, when
// zstd fails, or for an unknown encoding.
absl::StatusOr<std::vector<float>> DecodeImage(const v1::Image& image);
// Values per pixel of the image's encoding: 1, or 4 for 16UC4 and 32FC4; 0 when unknown.
int ImageChannels(const v1::Image& image);

// MOMENT_DEPTH: `map` (whole sensor) cropped to `rect` as 16UC4 (kOptimized64) or 32FC4
// (kFloat128), four values per pixel interleaved, and Image.moment_depth filled in (range,
// sigma, bits, bias, counters). The caller sets name, product and unit.
absl::Status EncodeMomentDepth(const MomentDepthMap& map, bool from_returns,
                               const PixelRect& rect, v1::Compression compression,
                               v1::Image* out);

// Client side: the moment depth map of a MOMENT_DEPTH image (its geometry is the image's, the
// stream's region of interest), ready for MomentDepthMap::Occlusion. DataLoss naming the image
// when moment_depth info is missing, bits and encoding disagree, the range is invalid, a
// 128-bit moment is not finite, or the data does not decode (DecodeImage).
absl::StatusOr<MomentDepthMap> DecodeMomentDepth(const v1::Image& image);

// IEEE 754 binary16 conversions, round to nearest even; NaN and infinities are kept.
uint16_t FloatToHalf(float value);
float HalfToFloat(uint16_t bits);

}  // namespace transient::wire

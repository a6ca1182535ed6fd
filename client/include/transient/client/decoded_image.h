// The images of a received frame as floats in their SI units, checked against the product
// registry: what a client of transientd works with instead of wire bytes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/product_registry.h"

namespace transient::client {

// Images wider or taller than this are not from a sensor: DecodeFrame refuses the frame.
inline constexpr uint32_t kMaxImageSide = 1 << 15;

// An image of a frame, decoded.
struct DecodedImage {
  std::string name;  // Image.name as sent: "range", "slices/12", "q_real/2"
  v1::Product product = v1::PRODUCT_UNSPECIFIED;
  wire::ImageKind kind = wire::ImageKind::kRange;
  int index = -1;     // slice n or harmonic j (wire::ImageIndex); -1 for single images
  std::string unit;   // of `values` (transient/reconstruct/units.h): "m" also for 16UC1 images
  ImageGeometry geometry;  // the stream's region of interest
  double time_of_flight_ns = 0.0;  // SLICES and CUMULATIVE: round-trip time of flight
  // One value per pixel, row-major, in `unit` (NaN = invalid; flags: the bits as 0..255);
  // MOMENT_DEPTH: four per pixel, interleaved (wire::DecodeImage).
  std::vector<float> values;
  std::optional<MomentDepthMap> moment_depth = std::nullopt;  // MOMENT_DEPTH only
  bool moment_depth_from_returns = false;
};

// Every image of `frame` decoded (wire::DecodeImage, and wire::DecodeMomentDepth for
// MOMENT_DEPTH). DataLoss naming the image and the frame when one is empty or larger than
// kMaxImageSide, is of a product the registry does not know, has a name, encoding or unit
// that its product does not send (wire::ParseImageName, SendsEncoding, WireUnit), or does not
// decode to width x height pixels.
[[nodiscard]] absl::StatusOr<std::vector<DecodedImage>> DecodeFrame(const v1::Frame& frame);

}  // namespace transient::client

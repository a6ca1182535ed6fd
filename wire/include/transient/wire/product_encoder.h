// A frame's products (reconstruct/frame_products.h) as transient.v1 images: what the daemon's
// streams send, and what a NATS reconstruction worker publishes, encoded one way.
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "transient/reconstruct/frame_products.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/image_codec.h"
#include "transient/wire/product_registry.h"

namespace transient::wire {

// Which products, of which region, how encoded.
struct ProductEncoding {
  std::vector<v1::Product> products;  // in the order the frame holds them, without repeats
  PixelRect rect;
  v1::Encoding encoding = v1::FLOAT32;
  v1::Compression compression = v1::COMPRESSION_NONE;
  std::vector<double> slice_phases;  // radians, for SLICES and CUMULATIVE
  MomentDepthSpec moment_depth;      // for MOMENT_DEPTH
};

// Names an encoded image of `kind` (index: its slice or harmonic) as the registry says: its
// name, product and unit.
void LabelImage(ImageKind kind, int index, v1::Image* image);

// What EncodeProducts's result depends on besides the frame: encodings with the same key are
// the same bytes (the daemon's streams share them). Phases as hexadecimal floats: exact.
std::string EncodingKey(const ProductEncoding& plan);

// Adds the images of `plan`'s products of `products` to `frame`. false when one is missing
// from `products` (computed before it was asked for).
absl::StatusOr<bool> EncodeProducts(const ProductEncoding& plan, const FrameProducts& products,
                                    v1::Frame* frame);

}  // namespace transient::wire

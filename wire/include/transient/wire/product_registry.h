// The products of transient.v1 in one table, beside the protocol: for every v1::Product its
// command-line and file name, the images it sends (Image.name), their units, the planes a
// frame of it holds and the encodings it may be sent in. The daemon names and checks what it
// sends with it, clients check what they receive against it, and the tools take their product
// names from it.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/v1/transient.pb.h"

namespace transient::wire {

// Every kind of image a frame can hold, whatever its product.
enum class ImageKind {
  kRange,        // RANGE
  kDepth,        // DEPTH
  kAmplitude,    // AMPLITUDE
  kC0,           // C0
  kFlags,        // FLAGS
  kCReal,        // MOMENT_STATE, per harmonic j = 0..m
  kCImag,        // MOMENT_STATE, per harmonic j = 1..m (c_0 is real)
  kQReal,        // MOMENT_STATE, per harmonic j = 0..m
  kQImag,        // MOMENT_STATE, per harmonic j = 0..m
  kSlice,        // SLICES, per slice n
  kCumulative,   // CUMULATIVE, per slice n
  kDirect,       // DIRECT_INDIRECT
  kIndirect,     // DIRECT_INDIRECT
  kMomentDepth,  // MOMENT_DEPTH
  kConfidence,   // CONFIDENCE
};

// How many images of one kind a frame holds, and how they are named.
enum class ImageIndex {
  kNone,             // one image, named by its stem: "range"
  kSlice,            // one per slice n = 0..N-1 of the request: "slices/n"
  kHarmonic,         // one per harmonic j = 0..m of the schedule: "c_real/j"
  kHarmonicFromOne,  // one per harmonic j = 1..m: "c_imag/j"
};

struct ImageSpec {
  ImageKind kind;
  v1::Product product;
  const char* stem;  // Image.name, or its part before "/index"
  ImageIndex index;
  // The unit of the image's values as floats (transient/reconstruct/units.h), which is what
  // clients decode to. On the wire a 16UC1 image says kMillimetres instead (WireUnit).
  const char* unit;
  int channels;  // values per pixel: 1, or 4 for MOMENT_DEPTH
};

// What a product's images may be sent as.
enum class EncodingRule {
  kFloat,               // FLOAT32 (32FC1) or FLOAT16 (16FC1)
  kFloatOrMillimetres,  // also UINT16_MM (16UC1): lengths only
  kFlags,               // always 8UC1; the requested encoding is ignored
  kMomentDepth,         // 16UC4 (64 bits) or 32FC4 (128 bits) by MomentDepthRequest.bits;
                        // the requested encoding is ignored
};

struct ProductSpec {
  v1::Product product;
  const char* name;  // `transient client --products`, file and folder names: "range"
  std::span<const ImageSpec> images;  // in the order a frame holds them
  EncodingRule encodings;
  // Which schedules can serve it: the moment reconstruction's products need every harmonic
  // 1..m (ScheduleOptions::HasAllHarmonics), phase unwrapping's need a schedule without.
  // kAny is also what a depth camera (SamplingScheme::kDepth) serves, from the depth it
  // delivers: RANGE, DEPTH, FLAGS, MOMENT_DEPTH, and AMPLITUDE when it delivers an amplitude
  // frame (the daemon checks that, and MOMENT_DEPTH of returns, beside this table).
  enum class Needs { kAny, kAllHarmonics, kHarmonicSet };
  Needs needs = Needs::kAny;
};

// At most this many SLICES (and as many CUMULATIVE) images in a frame: the daemon refuses a
// request for more.
inline constexpr int kMaxSlices = 1024;

// Every product, in the order of the enum: RANGE .. MOMENT_DEPTH.
std::span<const ProductSpec> Products();
// The spec of `product`; nullptr for PRODUCT_UNSPECIFIED and values the table does not know.
const ProductSpec* FindProduct(v1::Product product);
// The spec named `name` ("range"); nullptr when none is.
const ProductSpec* FindProduct(absl::string_view name);
// The names of Products(), in order: range, depth, ..., moment_depth.
std::vector<std::string> ProductNames();

const ImageSpec& Image(ImageKind kind);
// Image.name of the image of `kind` with `index` (ignored for ImageIndex::kNone): "slices/3".
std::string ImageName(ImageKind kind, int index = 0);
// Image.unit of an image of `kind` sent as `ros_encoding`: kMillimetres for "16UC1", else the
// spec's unit.
const char* WireUnit(ImageKind kind, absl::string_view ros_encoding);

// An image name of a product taken apart.
struct ImageRef {
  const ImageSpec* spec = nullptr;
  int index = -1;  // slice n or harmonic j; -1 for ImageIndex::kNone
};
// Which image of `product` is named `name`. InvalidArgument naming the name and the product's
// names when it is none of them, or its index is not a decimal number in range (slices below
// kMaxSlices; harmonics up to the core's kMaxOrder, from 1 for kHarmonicFromOne). The caller
// decides what that means for it (to a client, a corrupt image).
absl::StatusOr<ImageRef> ParseImageName(v1::Product product, absl::string_view name);

// The planes of one frame of `product` in 4-byte pixels, for memory bounds: its images times
// their channels, with `order` harmonics (m) and `slices` slices. 0 for an unknown product.
int64_t PlanesPerFrame(v1::Product product, int order, int slices);

// Whether an image of `product` may arrive in ROS encoding `ros_encoding` ("32FC1").
bool SendsEncoding(v1::Product product, absl::string_view ros_encoding);

// The command-line names of the encodings a client may ask for: float32, float16, mm.
struct EncodingChoice {
  v1::Encoding encoding;
  const char* name;
};
std::span<const EncodingChoice> EncodingChoices();
// The encoding named `name`; none when no choice is.
std::optional<v1::Encoding> FindEncoding(absl::string_view name);

}  // namespace transient::wire

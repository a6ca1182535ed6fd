// Frames as a client receives them: any bytes parsed as a transient.v1.Frame (the seeds are
// real frames of every encoding, compression and product, tests/fuzz/make_seeds.cc), then every
// image decoded as the client library and the wire codec decode it: DecodeFrame, DecodeImage,
// DecodeMomentDepth, half floats. Property: an image that decodes has width x height x
// channels values.
#include <google/protobuf/stubs/logging.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "transient/client/decoded_image.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/image_codec.h"

// Protobuf logs every string field with invalid UTF-8 it parses: thousands of lines a second
// of fuzzing, for what the parse result already says.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  transient::v1::Frame frame;
  if (!frame.ParseFromArray(data, static_cast<int>(size))) return 0;
  (void)transient::client::DecodeFrame(frame);
  for (const transient::v1::Image& image : frame.images()) {
    absl::StatusOr<std::vector<float>> values = transient::wire::DecodeImage(image);
    if (values.ok() &&
        values->size() != uint64_t{image.width()} * image.height() *
                              static_cast<uint64_t>(transient::wire::ImageChannels(image))) {
      std::abort();
    }
    (void)transient::wire::DecodeMomentDepth(image);
  }
  if (size >= 2) {
    uint16_t bits;
    std::memcpy(&bits, data, sizeof(bits));
    const float value = transient::wire::HalfToFloat(bits);
    // Every half float survives the round trip (NaN stays NaN).
    const uint16_t back = transient::wire::FloatToHalf(value);
    if (value == value && back != bits) std::abort();
  }
  return 0;
}

// The Kinect v2 over USB (docs/kinect2.md): isochronous packets of any lengths, statuses and
// contents (the input's bytes at each packet's end, where a sub-packet's footer lies, zeros
// before) through the stream parser and the frame assembler, each sub-image through the 11-bit
// unpacker; and the camera's answers to commands through their parsers. Property: the parser
// emits only whole sub-images, the assembler only frames of nine sub-frames.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "absl/time/time.h"
#include "kinect2/command.h"
#include "kinect2/kinect2_format.h"
#include "kinect2/stream_parser.h"

namespace kinect2 = transient::kinect2;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider input(data, size);
  const std::vector<uint8_t> response =
      input.ConsumeBytes<uint8_t>(input.ConsumeIntegralInRange<size_t>(0, 512));
  const uint32_t sequence = input.ConsumeIntegral<uint32_t>();
  (void)kinect2::CheckComplete(response, sequence);
  (void)kinect2::ParseFirmwareVersion(response);
  (void)kinect2::ParseSerial(response);
  (void)kinect2::ParseDepthIntrinsics(response);
  (void)kinect2::ParseStatus(response);

  std::vector<float> image(static_cast<size_t>(kinect2::kWidth) * kinect2::kHeight);
  kinect2::FrameAssembler assembler([&](std::vector<kinect2::SubFrame>&& frame) {
    if (frame.size() != static_cast<size_t>(kinect2::kCorrelationSubFrames)) std::abort();
  });
  kinect2::StreamParser parser([&](kinect2::SubFrame&& subframe) {
    if (subframe.payload.size() != kinect2::kSubImageBytes) std::abort();
    (void)kinect2::UnpackSubImage(subframe.payload, image);
    assembler.Add(std::move(subframe));
  });
  std::vector<uint8_t> packet;
  absl::Time now = absl::UnixEpoch();
  while (input.remaining_bytes() > 0) {
    packet.assign(input.ConsumeIntegralInRange<size_t>(0, kinect2::kIsoPacketBytes), 0);
    const std::vector<uint8_t> tail =
        input.ConsumeBytes<uint8_t>(input.ConsumeIntegralInRange<size_t>(0, 256));
    for (size_t i = 0; i < tail.size() && i < packet.size(); ++i) {
      packet[packet.size() - 1 - i] = tail[tail.size() - 1 - i];
    }
    const int status = input.ConsumeIntegralInRange(0, 3) == 0 ? -1 : 0;
    if (input.ConsumeIntegralInRange(0, 15) == 0) parser.Reset();
    parser.Feed({.data = packet, .status = status}, now);
    now += absl::Milliseconds(1);
  }
  return 0;
}

// A V4L2 camera's buffers (docs/v4l2.md): the unpacker with any format, layout and bytes, and
// the sequence assembler with any series of dequeued buffers (sequence numbers, timestamps,
// error flags, sizes). Property: the assembler places a buffer only at a phase 0..N-1.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <cstdlib>
#include <vector>

#include "v4l2/frame_unpacker.h"
#include "v4l2/sequence_assembler.h"

namespace v4l2 = transient::v4l2;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider input(data, size);
  constexpr uint32_t kFourccs[] = {v4l2::kFourccY12,     v4l2::kFourccY16,      v4l2::kFourccY12P,
                                   v4l2::kFourccSBGGR12, v4l2::kFourccSBGGR12P, 0x20202020u};
  v4l2::SampleFormat format;
  format.fourcc = input.PickValueInArray(kFourccs);
  format.bits = input.ConsumeIntegralInRange(-1, 17);
  format.shift = input.ConsumeIntegralInRange(-1, 16);
  format.is_signed = input.ConsumeBool();
  v4l2::FrameLayout layout;
  layout.geometry.width = input.ConsumeIntegralInRange(-2, 64);
  layout.geometry.height = input.ConsumeIntegralInRange(-2, 48);
  layout.bytes_per_line = input.ConsumeIntegralInRange<size_t>(0, 256);
  const int64_t pixels =
      layout.geometry.width > 0 && layout.geometry.height > 0 ? layout.geometry.pixel_count() : 0;
  std::vector<float> out(static_cast<size_t>(pixels) + input.ConsumeIntegralInRange(0, 1));

  v4l2::AssemblerOptions options;
  options.phases = input.ConsumeIntegralInRange(1, 12);
  options.alignment = input.PickValueInArray(
      {v4l2::Alignment::kTrigger, v4l2::Alignment::kSequence, v4l2::Alignment::kGap});
  options.expected_bytes = input.ConsumeIntegralInRange<size_t>(1, 4096);
  options.gap_ns = input.ConsumeIntegralInRange<int64_t>(0, 10'000'000);
  const size_t buffers = input.ConsumeIntegralInRange<size_t>(0, 64);
  std::vector<v4l2::DequeuedBuffer> dequeued;
  for (size_t i = 0; i < buffers && input.remaining_bytes() > 0; ++i) {
    dequeued.push_back({.sequence = input.ConsumeIntegral<uint32_t>(),
                        .timestamp_ns = input.ConsumeIntegral<int64_t>(),
                        .error_flag = input.ConsumeBool(),
                        .bytes_used = input.ConsumeBool() ? options.expected_bytes
                                                          : input.ConsumeIntegral<uint16_t>()});
  }
  const std::vector<uint8_t> bytes = input.ConsumeRemainingBytes<uint8_t>();
  (void)v4l2::Unpack(bytes, layout, format, out);

  if (!options.Validate().ok()) return 0;
  v4l2::SequenceAssembler assembler(options);
  for (size_t i = 0; i < dequeued.size(); ++i) {
    const uint8_t action = i < bytes.size() ? bytes[i] : 0;
    if (action == 1) assembler.Reset();
    if (action == 2) assembler.Abandon();
    if (action == 3) assembler.BeginSequence(dequeued[i].sequence);
    const v4l2::Placement placement = assembler.Add(dequeued[i]);
    if (placement.phase && (*placement.phase < 0 || *placement.phase >= options.phases)) {
      std::abort();
    }
  }
  return 0;
}

// The Kinect for Xbox One (Kinect v2) depth stream's data format, pure (no USB): the
// 11-bit companded samples, the row and column order of a sub-image, the 152-byte footer of a
// sub-packet, which sub-frame is which frequency and phase, and the P0 phase tables
// (../shared/research/libusb.md §1.3-§1.5, where each fact's source is named).
//
// One depth frame is 10 sub-packets (sub-frames 0..9), each a 512x424 sub-image of 11-bit
// samples (298,496 bytes) followed by a 152-byte footer. Sub-frames 0-2, 3-5 and 6-8 are the
// three phase steps (0, 120, 240 degrees) at 80, 16 and 120 MHz, harmonics 10, 2 and 15 of
// 8 MHz (unambiguous range 18.74 m); sub-frame 9 is undocumented and is recorded, not used.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/calibration.h"

namespace transient::kinect2 {

// Little-endian fields of the camera's blocks (footers, responses, tables).
inline uint32_t LoadLe32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}
inline uint16_t LoadLe16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }

inline constexpr int kWidth = 512;
inline constexpr int kHeight = 424;
inline constexpr int kBitsPerSample = 11;
inline constexpr size_t kRowBytes = kWidth * kBitsPerSample / 8;          // 704 (352 words)
inline constexpr size_t kSubImageBytes = kRowBytes * kHeight;             // 298,496
inline constexpr size_t kFooterBytes = 152;                               // 6 + 32 u32
inline constexpr size_t kSubPacketBytes = kSubImageBytes + kFooterBytes;  // 298,648
inline constexpr int kSubFrames = 10;            // per depth frame, 0..9
inline constexpr int kCorrelationSubFrames = 9;  // 0..8: three phases at three frequencies
inline constexpr size_t kIsoPacketBytes = 33792;  // 0x8400, wBytesPerInterval of EP 0x84
inline constexpr double kBaseFrequencyHz = 8e6;
// Harmonic j of kBaseFrequencyHz of sub-frame groups 0, 1, 2 (sub-frames 3g..3g+2).
inline constexpr int kGroupHarmonics[3] = {10, 2, 15};
inline constexpr double kTimestampUnitS = 125e-6;  // footer timestamps: 266 per frame at 30 Hz
inline constexpr double kFramePeriodS = 266 * kTimestampUnitS;  // 33.25 ms

// Samples: sign and companded magnitude. Codes 0..255 are the values 0..255; then six runs of
// 128 codes with steps 2, 4, .., 64 starting at 256, 512, .., 8192 (up to 16,320); code
// 1024 + x is -value(x), except that code 1024 marks a saturated sample.
inline constexpr uint16_t kSaturatedCode = 1024;
inline constexpr int16_t kSaturatedValue = 32767;
inline constexpr int kMaxMagnitude = 16320;
// value(code) for all 2048 codes (kSaturatedValue for kSaturatedCode).
const std::array<int16_t, 2048>& CompandingTable();
// The value a sample of `value` is read as: the nearest companded value, or kSaturatedValue
// when |value| exceeds the largest one by more than half its step (the simulated ADC).
float QuantizeSample(double value);

// Where pixel (x, row) of the upright output image is in a sub-image. The sensor reads out
// from the middle: output rows 0..211 are rows 0..211 of the sub-image, output rows 212..423
// are rows 423..212 (the output is libfreenect2's orientation; whether it is the scene's, or
// mirrored, is unverified without a camera). Within a row the samples are four interleaved
// groups of 128 columns: column x is slot (x / 4) + 128 * (x % 4), at bit 11 * slot of the row
// read as a little-endian bit stream.
int SubImageRow(int output_row);
int Slot(int x);

// One sub-image (kSubImageBytes) into kWidth * kHeight float samples in output order.
// Columns 0 and 511 carry no data (NaN); a saturated sample is kSaturatedValue, which the
// frame's saturation_level marks as saturated. InvalidArgument for a wrong size.
absl::Status UnpackSubImage(std::span<const uint8_t> payload, std::span<float> out);

// The footer of a sub-packet, little-endian u32s. `length` is the sub-image's size
// (kSubImageBytes); `timestamp` counts kTimestampUnitS; `sequence` is the depth frame's, the
// same for its ten sub-frames; `subsequence` the sub-frame 0..9. The magics and `fields` are
// undocumented and not checked.
struct Footer {
  uint32_t magic0 = 0, magic1 = 0, timestamp = 0, sequence = 0, subsequence = 0, length = 0;
  std::array<uint32_t, 32> fields{};
};
Footer ParseFooter(std::span<const uint8_t, kFooterBytes> bytes);

// The schedule of sub-frames 0..8: harmonics 10, 2, 15 of 8 MHz in capture order, 3 steps,
// c_0 not measured, one take. `exposure_s` is not reported by the device: nominal.
ScheduleOptions Schedule();
inline constexpr double kNominalExposureS = 1e-3;
// The exposure of correlation sub-frame `subframe` (0..8): harmonic kGroupHarmonics[s / 3] and
// phase step k = s % 3 at bucket phase shift -2*pi*k/3 (= 2*pi*((3 - k) % 3)/3) in the
// demodulator's convention (demodulation.h): libfreenect2 demodulates with
// sum_k m_k exp(-i*(2*pi*k/3 + p0)), i.e. sub-frame k measures Re(exp(+i*2*pi*k/3) c_j)
// (research/libusb.md §1.5).
ExposureConfig SubFrameExposure(int subframe);

// The P0 tables response (command 0x22, parameter 2): an 8 x u32 header, then per group
// g = 0, 1, 2: u16 pad, u16 table[424][512], u16 pad; then a tail. At least kP0ResponseBytes.
// The tables' rows are the output image's: libfreenect2 flips them vertically, and writes the
// pixel it computes from sub-image row SubImageRow(r) to output row r after flipping that
// too, so table row r pairs with output row r [derived from its code].
inline constexpr size_t kP0ResponseBytes = 32 + 3 * (2 + 2 * size_t{kWidth} * kHeight + 2);
// The phase offset of raw P0 value v, radians: -v * 0.000031 * pi (libfreenect2's constant,
// about 2*pi/65536; unverified against a camera).
double P0Phase(uint16_t value);
// The camera's factory calibration from its P0 tables: per pixel (output order) and harmonic j
// of group g, k_j = exp(-i * P0Phase(P0_g)) (unit modulus: the tables hold phases only), k = 1
// for the harmonics not measured. InvalidArgument when the response is too short.
absl::StatusOr<CalibrationTable> CalibrationFromP0(std::span<const uint8_t> response);

}  // namespace transient::kinect2

// One V4L2 buffer of raw ToF samples into float pixels: the pixel containers that raw-phase
// sensors stream through V4L2, their strides, and the interpretation of the samples (bit depth,
// an alignment shift, signed A-B tap differences). Pure: it works on bytes, not on a device
// (../shared/research/v4l2.md §1.1, §1.4, §2.2).
//
// Containers (fourccs as in linux/videodev2.h):
//   'Y12 ' Y12, 'BG12' SBGGR12: one sample in a 16-bit little-endian word, low-aligned
//                               (bits 15..12 zero);
//   'Y16 ' Y16:                 one sample in a 16-bit little-endian word;
//   'Y12P' Y12P, 'pBCC' SBGGR12P: MIPI CSI-2 RAW12, two samples in three bytes: byte 0 = P0[11:4],
//                               byte 1 = P1[11:4], byte 2 = P1[3:0] << 4 | P0[3:0].
// The Bayer names are only containers here: a ToF sensor's "Bayer" data is one sample per pixel.
// Y12P is not in Debian 12's kernel headers (it came later), so the fourccs are spelled here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/image.h"

namespace transient::v4l2 {

constexpr uint32_t Fourcc(char a, char b, char c, char d) {
  return static_cast<uint32_t>(static_cast<uint8_t>(a)) |
         static_cast<uint32_t>(static_cast<uint8_t>(b)) << 8 |
         static_cast<uint32_t>(static_cast<uint8_t>(c)) << 16 |
         static_cast<uint32_t>(static_cast<uint8_t>(d)) << 24;
}

constexpr uint32_t kFourccY12 = Fourcc('Y', '1', '2', ' ');
constexpr uint32_t kFourccY16 = Fourcc('Y', '1', '6', ' ');
constexpr uint32_t kFourccY12P = Fourcc('Y', '1', '2', 'P');
constexpr uint32_t kFourccSBGGR12 = Fourcc('B', 'G', '1', '2');
constexpr uint32_t kFourccSBGGR12P = Fourcc('p', 'B', 'C', 'C');

// The four characters of a fourcc, non-printable bytes as \xNN, e.g. "Y12P".
std::string FourccName(uint32_t fourcc);

enum class Container {
  kLittleEndian16,  // Y12, SBGGR12, Y16
  kMipiRaw12,       // Y12P, SBGGR12P
};

// How the samples of a buffer are read: the container of `fourcc`, then `shift` bits dropped
// on the right, then `bits` bits kept; signed samples are two's complement in those bits (the
// A-B tap difference of a two-tap pixel, e.g. the MLX7502x's default output).
struct SampleFormat {
  uint32_t fourcc = kFourccY12;
  int bits = 12;          // 1..16; at most 12 for the 12-bit containers
  int shift = 0;          // 0..15, bits + shift <= the container's bits (12 or 16)
  bool is_signed = false;

  // InvalidArgument naming the field: an unknown fourcc (named, with the ones we read), bits or
  // shift out of range for the container.
  absl::Status Validate() const;
};

// The memory layout the driver reported for a buffer (VIDIOC_S_FMT's read-back).
struct FrameLayout {
  ImageGeometry geometry;
  size_t bytes_per_line = 0;  // the driver's stride; at least the packed row size
};

// The bytes of one row's samples without padding: 2 per sample, or 3 per 2 samples.
// InvalidArgument for an odd width in a MIPI RAW12 container (it packs samples in pairs).
absl::StatusOr<size_t> RowBytes(uint32_t fourcc, int width);

// Checks `layout` against `format`: positive size, a stride at least the row's bytes.
// InvalidArgument naming both values.
absl::Status CheckLayout(const FrameLayout& layout, const SampleFormat& format);

// Unpacks one buffer into `pixels` (row-major, geometry.pixel_count() values). InvalidArgument
// when `format` or `layout` is invalid (as Validate and CheckLayout say) or `pixels` has the
// wrong size. DataLoss, naming the sizes, when `data` holds fewer than
// bytes_per_line * (height - 1) + row bytes (a short buffer); DataLoss naming the pixel when a
// sample has bits above `bits + shift` set (the data is not what the format says: a driver that
// puts 12-bit samples high in a 16-bit word needs shift=4). On DataLoss `pixels` may be partly
// written: the frame is to be dropped.
absl::Status Unpack(std::span<const uint8_t> data, const FrameLayout& layout,
                    const SampleFormat& format, std::span<float> pixels);

}  // namespace transient::v4l2

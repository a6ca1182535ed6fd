// The Kinect v2's command protocol over its bulk endpoints, pure: the encoding of a command,
// the "response complete" block, and the responses the source reads at open
// (../shared/research/libusb.md §1.2). The same family of protocol as the Azure Kinect's.
//
// A command goes to bulk OUT 0x02 as little-endian u32s {magic 0x06022009, sequence,
// max_response_length, command, 0, params...}. When max_response_length > 0 one bulk IN on
// 0x81 brings the response (at most that long); then a 16-byte block {0x0A6FE000, sequence, ..}
// on 0x81 says the command is complete.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace transient::kinect2 {

inline constexpr uint32_t kCommandMagic = 0x06022009;
inline constexpr uint32_t kCompleteMagic = 0x0A6FE000;
inline constexpr size_t kCompleteBytes = 16;

// Command ids.
enum Command : uint32_t {
  kReadFirmwareVersions = 0x02,
  kInitStreams = 0x09,
  kStop = 0x0A,
  kReadHardwareInfo = 0x14,
  kReadStatus = 0x16,
  kReadData = 0x22,  // param: kDataSerial, kDataP0Tables, kDataDepthIntrinsics, kDataRgbParams
  kSetStreaming = 0x2B,
  kSetMode = 0x4B,
};
inline constexpr uint32_t kDataSerial = 1, kDataP0Tables = 2, kDataDepthIntrinsics = 3,
                          kDataRgbParams = 4;
inline constexpr uint32_t kStatusParam = 0x090000;  // kReadStatus: bit 0 = ready to stream
inline constexpr uint32_t kMaxDataResponse = 0x1C0000;

// "firmware versions (0x02)", "read data (0x22)", ...; unknown ids as hex.
std::string CommandName(uint32_t command);

std::vector<uint8_t> EncodeCommand(uint32_t sequence, uint32_t command,
                                   uint32_t max_response_length,
                                   std::span<const uint32_t> params);

// Checks a response-complete block: 16 bytes, the magic, and the command's sequence.
// DataLoss naming what differs ("response complete for sequence 7, expected 6").
absl::Status CheckComplete(std::span<const uint8_t> block, uint32_t sequence);

// The firmware version of the main blob: entry 3 of the 16-byte entries {u32 major << 16 |
// minor, revision, build, reserved}, as "4.0.3912.0". DataLoss when too short.
absl::StatusOr<std::string> ParseFirmwareVersion(std::span<const uint8_t> response);

// The serial: every other byte (UTF-16LE) up to the first 0. DataLoss when empty.
absl::StatusOr<std::string> ParseSerial(std::span<const uint8_t> response);

// The depth camera's intrinsics: 23 little-endian floats {fx, fy, 0, cx, cy, k1, k2, p1, p2,
// k3, 13 more}, 92 bytes (the layout libfreenect2 reads; p1, p2 "always seen as zero").
struct DepthIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> distortion{};  // k1, k2, p1, p2, k3 (ROS plumb_bob order)
};
inline constexpr size_t kDepthIntrinsicsBytes = 92;
// DataLoss when shorter than 92 bytes or a focal length is not finite and > 0.
absl::StatusOr<DepthIntrinsics> ParseDepthIntrinsics(std::span<const uint8_t> response);

// The status word of kReadStatus (4 bytes, little-endian). DataLoss when shorter.
absl::StatusOr<uint32_t> ParseStatus(std::span<const uint8_t> response);

}  // namespace transient::kinect2

// The Kinect v2's command protocol (command.h).
#include "kinect2/command.h"

#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "kinect2/kinect2_format.h"

namespace transient::kinect2 {
namespace {

float ReadFloat(const uint8_t* p) {
  const uint32_t bits = LoadLe32(p);
  float value;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

void PutU32(uint32_t v, std::vector<uint8_t>* out) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}

}  // namespace

std::string CommandName(uint32_t command) {
  switch (command) {
    case kReadFirmwareVersions: return "firmware versions (0x02)";
    case kInitStreams: return "init streams (0x09)";
    case kStop: return "stop (0x0A)";
    case kReadHardwareInfo: return "hardware info (0x14)";
    case kReadStatus: return "status (0x16)";
    case kReadData: return "read data (0x22)";
    case kSetStreaming: return "set streaming (0x2B)";
    case kSetMode: return "set mode (0x4B)";
  }
  return absl::StrFormat("command 0x%02X", command);
}

std::vector<uint8_t> EncodeCommand(uint32_t sequence, uint32_t command,
                                   uint32_t max_response_length,
                                   std::span<const uint32_t> params) {
  std::vector<uint8_t> out;
  out.reserve(20 + 4 * params.size());
  PutU32(kCommandMagic, &out);
  PutU32(sequence, &out);
  PutU32(max_response_length, &out);
  PutU32(command, &out);
  PutU32(0, &out);
  for (uint32_t p : params) PutU32(p, &out);
  return out;
}

absl::Status CheckComplete(std::span<const uint8_t> block, uint32_t sequence) {
  if (block.size() != kCompleteBytes) {
    return absl::DataLossError(absl::StrCat("response complete of ", block.size(),
                                            " bytes, expected ", kCompleteBytes));
  }
  const uint32_t magic = LoadLe32(block.data());
  if (magic != kCompleteMagic) {
    return absl::DataLossError(absl::StrFormat(
        "response complete with magic 0x%08X, expected 0x%08X", magic, kCompleteMagic));
  }
  const uint32_t got = LoadLe32(block.data() + 4);
  if (got != sequence) {
    return absl::DataLossError(
        absl::StrCat("response complete for sequence ", got, ", expected ", sequence));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> ParseFirmwareVersion(std::span<const uint8_t> response) {
  constexpr size_t kEntry = 16, kMain = 3;
  if (response.size() < (kMain + 1) * kEntry) {
    return absl::DataLossError(absl::StrCat("firmware versions response of ", response.size(),
                                            " bytes; expected at least ", (kMain + 1) * kEntry));
  }
  const uint8_t* e = response.data() + kMain * kEntry;
  const uint32_t major_minor = LoadLe32(e);
  return absl::StrCat(major_minor >> 16, ".", major_minor & 0xFFFF, ".", LoadLe32(e + 4), ".",
                      LoadLe32(e + 8));
}

absl::StatusOr<std::string> ParseSerial(std::span<const uint8_t> response) {
  std::string serial;
  for (size_t i = 0; i < response.size(); i += 2) {
    if (response[i] == 0) break;
    serial.push_back(static_cast<char>(response[i]));
  }
  if (serial.empty()) return absl::DataLossError("empty serial number response");
  return serial;
}

absl::StatusOr<DepthIntrinsics> ParseDepthIntrinsics(std::span<const uint8_t> response) {
  if (response.size() < kDepthIntrinsicsBytes) {
    return absl::DataLossError(absl::StrCat("depth intrinsics response of ", response.size(),
                                            " bytes; expected ", kDepthIntrinsicsBytes));
  }
  const uint8_t* p = response.data();
  DepthIntrinsics d;
  d.fx = ReadFloat(p);
  d.fy = ReadFloat(p + 4);
  d.cx = ReadFloat(p + 12);
  d.cy = ReadFloat(p + 16);
  const double k1 = ReadFloat(p + 20), k2 = ReadFloat(p + 24), p1 = ReadFloat(p + 28),
               p2 = ReadFloat(p + 32), k3 = ReadFloat(p + 36);
  d.distortion = {k1, k2, p1, p2, k3};
  for (double v : {d.fx, d.fy}) {
    if (!std::isfinite(v) || v <= 0.0) {
      return absl::DataLossError(
          absl::StrCat("depth intrinsics: focal length ", v, "; expected finite and > 0"));
    }
  }
  for (double v : {d.cx, d.cy, k1, k2, p1, p2, k3}) {
    if (!std::isfinite(v)) return absl::DataLossError("depth intrinsics: a non-finite value");
  }
  return d;
}

absl::StatusOr<uint32_t> ParseStatus(std::span<const uint8_t> response) {
  if (response.size() < 4) {
    return absl::DataLossError(
        absl::StrCat("status response of ", response.size(), " bytes; expected 4"));
  }
  return LoadLe32(response.data());
}

}  // namespace transient::kinect2

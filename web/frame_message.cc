#include "transient/web/frame_message.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/wire/image_codec.h"

namespace transient::web {
namespace {

// A JSON string literal of `text` (names and units: printable ASCII, escaped all the same).
std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      absl::StrAppendFormat(&out, "\\u%04x", static_cast<unsigned char>(c));
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// A finite number as JSON, or null.
std::string JsonNumber(double value) {
  return std::isfinite(value) ? absl::StrFormat("%.9g", value) : "null";
}

void AppendUint32(std::string* out, uint32_t value) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

}  // namespace

std::string EncodeFrameMessage(const client::StreamFrame& frame) {
  std::string header = absl::StrFormat(
      "{\"sequence\":%d,\"captureTimeS\":%s,\"latencyMs\":%s,\"missed\":%d", frame.sequence,
      JsonNumber(frame.capture_time_s), JsonNumber(frame.latency_s * 1e3), frame.missed);
  const ImageGeometry geometry =
      frame.images.empty() ? ImageGeometry{} : frame.images.front().geometry;
  absl::StrAppend(&header, ",\"width\":", geometry.width, ",\"height\":", geometry.height,
                  ",\"images\":[");
  std::string payload;
  bool first = true;
  for (const client::DecodedImage& image : frame.images) {
    // One value per pixel: moment depth maps (four) are not for the page.
    if (image.values.size() != static_cast<size_t>(image.geometry.pixel_count())) continue;
    const bool bytes = image.kind == wire::ImageKind::kFlags;
    const size_t offset = payload.size();
    if (bytes) {
      for (const float v : image.values) {
        // NaN (no flags known) as 0.
        const float bits = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 255.0f);
        payload.push_back(static_cast<char>(static_cast<uint8_t>(bits)));
      }
    } else {
      for (const float v : image.values) {
        const uint16_t half = wire::FloatToHalf(v);
        payload.push_back(static_cast<char>(half & 0xff));
        payload.push_back(static_cast<char>(half >> 8));
      }
    }
    const size_t length = payload.size() - offset;
    payload.resize((payload.size() + 3) / 4 * 4, '\0');
    absl::StrAppend(&header, first ? "" : ",", "{\"name\":", JsonString(image.name),
                    ",\"unit\":", JsonString(image.unit), ",\"type\":\"", bytes ? "u8" : "f16",
                    "\",\"offset\":", offset, ",\"length\":", length);
    if (image.kind == wire::ImageKind::kSlice || image.kind == wire::ImageKind::kCumulative) {
      absl::StrAppend(&header, ",\"tofNs\":", JsonNumber(image.time_of_flight_ns));
    }
    header += "}";
    first = false;
  }
  header += "]}";
  header.resize((header.size() + 3) / 4 * 4, ' ');
  std::string message(kFrameMagic, sizeof(kFrameMagic));
  AppendUint32(&message, static_cast<uint32_t>(header.size()));
  message += header;
  message += payload;
  return message;
}

}  // namespace transient::web

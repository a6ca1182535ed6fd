#include "device_uri.h"

#include <cmath>
#include <cstdlib>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "drivers/src/source_uri.h"

namespace transient::openni2 {
namespace {

// The sizes a stream may be given: the sensor's own or one of OpenNI2's standard ones.
bool ParseSize(absl::string_view text, int* width, int* height) {
  if (text == "native") {
    *width = *height = 0;
    return true;
  }
  const std::vector<absl::string_view> parts = absl::StrSplit(text, 'x');
  return parts.size() == 2 && absl::SimpleAtoi(parts[0], width) &&
         absl::SimpleAtoi(parts[1], height) && *width >= 1 && *width <= 4096 && *height >= 1 &&
         *height <= 4096;
}

}  // namespace

std::string DeviceUriOf(absl::string_view address) { return absl::StrCat(kUriScheme, address); }

client::ChannelSecurity SecurityFromEnvironment() {
  auto variable = [](const char* name) {
    const char* value = std::getenv(name);
    return value == nullptr ? std::string() : std::string(value);
  };
  return {.ca_file = variable("TRANSIENT_OPENNI2_CA_FILE"),
          .cert_file = variable("TRANSIENT_OPENNI2_CERT_FILE"),
          .key_file = variable("TRANSIENT_OPENNI2_KEY_FILE"),
          .server_name = variable("TRANSIENT_OPENNI2_SERVER_NAME"),
          .token_file = variable("TRANSIENT_OPENNI2_TOKEN_FILE")};
}

absl::StatusOr<DeviceUri> ParseDeviceUri(absl::string_view uri) {
  if (!absl::StartsWith(uri, kUriScheme)) {
    return absl::NotFoundError(absl::StrCat("'", uri, "' is not a ", kUriScheme, " URI"));
  }
  // transient://HOST:PORT?k=v as the project's URI syntax "scheme:target?k=v".
  absl::StatusOr<internal::SourceUri> parts =
      internal::ParseSourceUri(absl::StrCat("transient:", uri.substr(kUriScheme.size())));
  if (!parts.ok()) return parts.status();
  DeviceUri out;
  out.uri = std::string(uri);
  out.address = parts->target;
  if (out.address.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(uri, ": no daemon address; expected transient://HOST:PORT"));
  }
  for (const auto& [key, value] : parts->keys) {
    if (key == "unit") {
      if (value == "mm") {
        out.unit = DepthUnit::kMillimetre;
      } else if (value == "100um") {
        out.unit = DepthUnit::kHundredMicrometre;
      } else {
        return internal::BadKeyValue(uri, key, value, "mm or 100um");
      }
    } else if (key == "size") {
      if (!ParseSize(value, &out.width, &out.height)) {
        return internal::BadKeyValue(uri, key, value, "WxH (1..4096 each) or native");
      }
    } else if (key == "ir_scale") {
      if (!absl::SimpleAtod(value, &out.ir_scale) || !std::isfinite(out.ir_scale) ||
          out.ir_scale <= 0.0) {
        return internal::BadKeyValue(uri, key, value, "a number > 0");
      }
    } else {
      return absl::InvalidArgumentError(
          absl::StrCat(uri, ": unknown key '", key, "'; expected unit, size or ir_scale"));
    }
  }
  return out;
}

}  // namespace transient::openni2

// The URIs of the OpenNI2 driver's devices: transient://HOST:PORT[?key=value&...], a transientd
// at HOST:PORT (or transient://unix:PATH). Keys:
//   unit=mm|100um   the depth stream's default pixel format, DEPTH_1_MM (default) or DEPTH_100_UM
//   size=WxH        the default size of every stream (default 640x480: what OpenNI2 applications
//                   ask for; `native` = the sensor's); offered as a mode beside the sensor's,
//                   640x480 and 320x240
//   ir_scale=S      IR (amplitude) counts per sensor unit, > 0 (default 1)
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/client/client.h"
#include "transient/openni2/oni_frames.h"

namespace transient::openni2 {

inline constexpr absl::string_view kUriScheme = "transient://";

struct DeviceUri {
  std::string uri;      // as given
  std::string address;  // the gRPC target: host:port or unix:PATH
  DepthUnit unit = DepthUnit::kMillimetre;
  int width = 640, height = 480;  // 0, 0 = the sensor's size
  double ir_scale = 1.0;
};

// The URI of the daemon at `address` with no keys.
std::string DeviceUriOf(absl::string_view address);

// How the driver reaches a daemon that requires TLS or a token (docs/security.md): from the
// environment of the application, which cannot pass options to a driver. Files, never secrets:
// TRANSIENT_OPENNI2_CA_FILE, _CERT_FILE, _KEY_FILE, _SERVER_NAME, _TOKEN_FILE.
client::ChannelSecurity SecurityFromEnvironment();

// InvalidArgument naming the part that is wrong (an empty address, an unknown key, a bad value);
// NotFound when `uri` is not a transient:// URI (another driver's).
absl::StatusOr<DeviceUri> ParseDeviceUri(absl::string_view uri);

}  // namespace transient::openni2

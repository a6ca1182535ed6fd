// The capture devices of this machine (capture_devices.h): one call per source family.
#include "transient/drivers/capture_devices.h"

#include "absl/strings/str_cat.h"
#include "v4l2/v4l2_devices.h"

namespace transient {

std::vector<CaptureDevice> ListCaptureDevices(const std::string& dev_dir) {
  return v4l2::ListV4l2Devices(dev_dir);
}

std::string DescribeCaptureDevices(const std::vector<CaptureDevice>& devices,
                                   const std::string& dev_dir) {
  if (devices.empty()) {
    return absl::StrCat("no capture devices found (looked for V4L2 nodes ", dev_dir,
                        "/videoN)\n");
  }
  std::string text;
  for (const CaptureDevice& device : devices) {
    absl::StrAppend(&text, device.uri, device.name.empty() ? "" : absl::StrCat("  ", device.name),
                    device.usable ? "" : "  (not usable)", "\n");
    for (const std::string& line : device.details) absl::StrAppend(&text, "  ", line, "\n");
  }
  return text;
}

}  // namespace transient

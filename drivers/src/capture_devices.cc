// The capture devices of this machine (capture_devices.h): one call per source family.
#include "transient/drivers/capture_devices.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "kinect2/usb_kinect2.h"
#include "openni2/openni2_source.h"
#include "v4l2/v4l2_devices.h"

namespace transient {

std::vector<CaptureDevice> ListCaptureDevices(const DeviceListOptions& options) {
  std::vector<CaptureDevice> devices = v4l2::ListV4l2Devices(options.dev_dir);
  for (const kinect2::Kinect2Listing& k : kinect2::ListKinect2()) {
    CaptureDevice device;
    device.uri = k.serial.empty() ? "usb:kinect2" : absl::StrCat("usb:kinect2?serial=", k.serial);
    device.name = "Microsoft Kinect v2";
    device.usable = k.problem.empty();
    device.details.push_back(absl::StrFormat("USB 045e:%04x at bus %03d device %03d, %d Mbit/s",
                                             k.product_id, k.bus, k.address, k.speed_mbps));
    if (!k.serial.empty()) device.details.push_back(absl::StrCat("serial ", k.serial));
    if (!k.problem.empty()) device.details.push_back(k.problem);
    devices.push_back(device);
  }
  if (options.openni2) {
    for (CaptureDevice& device : openni2::ListOpenNi2Devices()) {
      devices.push_back(std::move(device));
    }
  }
  return devices;
}

std::string DescribeCaptureDevices(const std::vector<CaptureDevice>& devices,
                                   const DeviceListOptions& options) {
  if (devices.empty()) {
    return absl::StrCat("no capture devices found (looked for V4L2 nodes ", options.dev_dir,
                        options.openni2 ? "/videoN, Kinect v2 cameras on USB and OpenNI2 devices)\n"
                                        : "/videoN and Kinect v2 cameras on USB)\n");
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

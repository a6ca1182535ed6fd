// The capture devices this machine shows, for `transient devices`: what a user can put in a
// source URI. V4L2 nodes (/dev/videoN with their formats and whether the proposed ToF
// controls are there), Kinect v2 cameras on USB (serial, speed) and the devices OpenNI2
// enumerates (openni2:).
#pragma once

#include <string>
#include <vector>

namespace transient {

struct CaptureDevice {
  std::string uri;                   // what to pass to --source, e.g. "v4l2:/dev/video0"
  std::string name;                  // the device's own name (V4L2: the card)
  bool usable = false;               // a capture device we can read
  std::vector<std::string> details;  // one line each: driver, formats, controls, or what is wrong
};

// Where to look.
struct DeviceListOptions {
  std::string dev_dir = "/dev";  // where V4L2 device nodes are
  // Also the devices OpenNI2's drivers enumerate. OpenNI2 loads every driver in its folder into
  // the process, and its USB drivers open and watch USB devices themselves: off where that must
  // not happen (`transient devices --no-openni2`; tests of emulated devices).
  bool openni2 = true;
};

// Every device found, in order (V4L2: /dev/videoN by N; then the Kinect v2 cameras, then
// OpenNI2's).
std::vector<CaptureDevice> ListCaptureDevices(const DeviceListOptions& options = {});

// The list as text; with no devices, one line saying so and where it looked.
std::string DescribeCaptureDevices(const std::vector<CaptureDevice>& devices,
                                   const DeviceListOptions& options = {});

}  // namespace transient

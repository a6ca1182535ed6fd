// The V4L2 part of `transient devices` (capture_devices.h): every /dev/videoN with its
// capabilities, formats (which of them we read) and ToF controls, or what is wrong with it.
#pragma once

#include <string>
#include <vector>

#include "transient/drivers/capture_devices.h"

namespace transient::v4l2 {

std::vector<CaptureDevice> ListV4l2Devices(const std::string& dev_dir);

}  // namespace transient::v4l2

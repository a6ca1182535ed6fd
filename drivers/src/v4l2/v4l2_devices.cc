// Listing V4L2 nodes (v4l2_devices.h).
#include "v4l2/v4l2_devices.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "v4l2/frame_unpacker.h"
#include "v4l2/v4l2_device.h"

namespace transient::v4l2 {
namespace {

// N of a "videoN" name, or -1.
int VideoNodeNumber(const std::string& name) {
  constexpr std::string_view kPrefix = "video";
  if (name.size() <= kPrefix.size() || name.compare(0, kPrefix.size(), kPrefix) != 0) return -1;
  int number = 0;
  for (size_t i = kPrefix.size(); i < name.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(name[i])) || number > 100000) return -1;
    number = number * 10 + (name[i] - '0');
  }
  return number;
}

CaptureDevice Describe(const std::string& path) {
  CaptureDevice device;
  device.uri = absl::StrCat("v4l2:", path);
  absl::StatusOr<V4l2Device> opened = V4l2Device::Open(path);
  if (!opened.ok()) {
    device.details.push_back(absl::StrCat("cannot open: ", opened.status().message()));
    return device;
  }
  absl::StatusOr<Capabilities> caps = opened->QueryCapabilities();
  if (!caps.ok()) {
    device.details.push_back(std::string(caps.status().message()));
    return device;
  }
  device.name = caps->card;
  device.details.push_back(absl::StrCat("driver ", caps->driver, ", bus ", caps->bus_info));
  if (!caps->capture() || !caps->streaming()) {
    device.details.push_back(
        "not a streaming video capture node (a metadata, output or subdevice node?)");
    return device;
  }
  absl::StatusOr<std::vector<PixelFormatDescription>> formats = opened->EnumerateFormats();
  if (!formats.ok()) {
    device.details.push_back(std::string(formats.status().message()));
    return device;
  }
  std::vector<std::string> readable, other;
  for (const PixelFormatDescription& format : *formats) {
    const bool ours = (SampleFormat{.fourcc = format.fourcc}).Validate().ok();
    (ours ? readable : other).push_back(FourccName(format.fourcc));
  }
  device.details.push_back(absl::StrCat(
      "raw formats we read: ", readable.empty() ? "none" : absl::StrJoin(readable, ", "),
      other.empty() ? "" : absl::StrCat("; others: ", absl::StrJoin(other, ", "))));
  absl::StatusOr<std::vector<ControlDescription>> controls = opened->EnumerateControls();
  if (!controls.ok()) {
    device.details.push_back(std::string(controls.status().message()));
  } else {
    int tof = 0;
    for (const ControlDescription& control : *controls) {
      if (!IsTofControl(control)) continue;
      ++tof;
      device.details.push_back(absl::StrFormat("ToF control 0x%08x \"%s\": %s", control.id,
                                               control.name, DescribeControlRange(control)));
    }
    if (tof == 0) {
      device.details.push_back(absl::StrCat(
          "no ToF controls on this node (", controls->size(),
          " controls); on sensors like the MLX7502x they are on the sensor's /dev/v4l-subdevN"));
    }
  }
  device.usable = !readable.empty();
  return device;
}

}  // namespace

std::vector<CaptureDevice> ListV4l2Devices(const std::string& dev_dir) {
  std::vector<std::pair<int, std::string>> nodes;
  std::error_code error;
  for (std::filesystem::directory_iterator it(dev_dir, error), end; !error && it != end;
       it.increment(error)) {
    const std::string name = it->path().filename().string();
    const int number = VideoNodeNumber(name);
    if (number >= 0) nodes.emplace_back(number, it->path().string());
  }
  std::sort(nodes.begin(), nodes.end());
  std::vector<CaptureDevice> devices;
  for (const auto& [number, path] : nodes) devices.push_back(Describe(path));
  return devices;
}

}  // namespace transient::v4l2

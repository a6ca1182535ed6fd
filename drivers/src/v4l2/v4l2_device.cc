// A V4L2 device node through ioctl (v4l2_device.h).
#include "v4l2/v4l2_device.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace transient::v4l2 {
namespace {

// A fixed-size, NUL-padded char array of the kernel's structs as a string.
template <size_t N>
std::string FieldText(const uint8_t (&field)[N]) {
  size_t length = 0;
  while (length < N && field[length] != 0) ++length;
  return std::string(reinterpret_cast<const char*>(field), length);
}
template <size_t N>
std::string FieldText(const char (&field)[N]) {
  return std::string(field, strnlen(field, N));
}

constexpr int kMaxEnumerated = 1024;  // a driver that never says EINVAL is not believed further

}  // namespace

bool Capabilities::capture() const {
  return (device_caps & (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_VIDEO_CAPTURE_MPLANE)) != 0;
}
bool Capabilities::streaming() const { return (device_caps & V4L2_CAP_STREAMING) != 0; }

bool ControlDescription::dynamic_array() const {
  return (flags & V4L2_CTRL_FLAG_DYNAMIC_ARRAY) != 0;
}

bool IsTofControl(const ControlDescription& control) {
  if ((control.id & 0xffff0000u) == kTofControlClass) return true;
  if (control.id == kCidCameraTrigger || control.id == kCidCameraTriggerMode) return true;
  for (const char* name : {"TOF Phase Sequence", "TOF Frequency Modulation",
                           "TOF Time Integration", "Camera Trigger", "Camera Trigger Mode"}) {
    if (control.name == name) return true;
  }
  return false;
}

std::string DescribeControlRange(const ControlDescription& c) {
  std::string type;
  switch (c.type) {
    case V4L2_CTRL_TYPE_INTEGER:
      type = "int";
      break;
    case V4L2_CTRL_TYPE_INTEGER64:
      type = "int64";
      break;
    case V4L2_CTRL_TYPE_BOOLEAN:
      type = "bool";
      break;
    case V4L2_CTRL_TYPE_MENU:
    case V4L2_CTRL_TYPE_INTEGER_MENU:
      type = "menu";
      break;
    case V4L2_CTRL_TYPE_BUTTON:
      return "button";
    case V4L2_CTRL_TYPE_U8:
      type = "u8";
      break;
    case V4L2_CTRL_TYPE_U16:
      type = "u16";
      break;
    case V4L2_CTRL_TYPE_U32:
      type = "u32";
      break;
    default:
      type = absl::StrCat("type ", c.type);
  }
  if (c.elements > 1 || c.dynamic_array()) {
    absl::StrAppend(&type, "[", c.dynamic_array() ? "<=" : "", c.elements, "]");
  }
  absl::StrAppend(&type, " ", c.minimum, "..", c.maximum);
  if (c.step > 1) absl::StrAppend(&type, " step ", c.step);
  return type;
}

absl::StatusOr<V4l2Device> V4l2Device::Open(const std::string& path) {
  // stat, not fstat: emulated nodes are character devices to stat (research §3.1).
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    const int error = errno;
    const std::string text = absl::StrCat(path, ": ", std::strerror(error));
    if (error == ENOENT) return absl::NotFoundError(text);
    if (error == EACCES) return absl::PermissionDeniedError(text);
    return absl::UnavailableError(text);
  }
  if (!S_ISCHR(info.st_mode)) {
    return absl::FailedPreconditionError(absl::StrCat(path, ": not a character device"));
  }
  const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    const std::string text = absl::StrCat(path, ": ", std::strerror(error));
    if (error == ENOENT || error == ENXIO) return absl::NotFoundError(text);
    if (error == EACCES || error == EPERM) return absl::PermissionDeniedError(text);
    if (error == EBUSY) {
      return absl::UnavailableError(absl::StrCat(text, " (another program may own it)"));
    }
    return absl::UnavailableError(text);
  }
  return V4l2Device(fd, path);
}

V4l2Device::V4l2Device(V4l2Device&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}

V4l2Device& V4l2Device::operator=(V4l2Device&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
  }
  return *this;
}

V4l2Device::~V4l2Device() {
  if (fd_ >= 0) ::close(fd_);
}

int V4l2Device::Ioctl(unsigned long request, void* argument) const {
  int result;
  do {
    result = ::ioctl(fd_, request, argument);
  } while (result == -1 && errno == EINTR);
  return result;
}

absl::Status V4l2Device::IoctlError(const char* what, int error) const {
  const std::string text = absl::StrCat(path_, ": ", what, ": ", std::strerror(error));
  if (error == ENODEV) return absl::UnavailableError(absl::StrCat(text, " (device gone)"));
  if (error == ENOTTY) return absl::FailedPreconditionError(absl::StrCat(text, " (not a V4L2 node)"));
  return absl::InternalError(text);
}

absl::StatusOr<Capabilities> V4l2Device::QueryCapabilities() {
  v4l2_capability cap{};
  if (Ioctl(VIDIOC_QUERYCAP, &cap) != 0) return IoctlError("VIDIOC_QUERYCAP", errno);
  Capabilities result;
  result.driver = FieldText(cap.driver);
  result.card = FieldText(cap.card);
  result.bus_info = FieldText(cap.bus_info);
  result.device_caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? cap.device_caps : cap.capabilities;
  return result;
}

absl::StatusOr<std::vector<PixelFormatDescription>> V4l2Device::EnumerateFormats() {
  std::vector<PixelFormatDescription> formats;
  for (uint32_t index = 0; index < kMaxEnumerated; ++index) {
    v4l2_fmtdesc description{};
    description.index = index;
    description.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (Ioctl(VIDIOC_ENUM_FMT, &description) != 0) {
      if (errno == EINVAL) return formats;
      return IoctlError("VIDIOC_ENUM_FMT", errno);
    }
    formats.push_back({description.pixelformat, FieldText(description.description)});
  }
  return absl::InternalError(absl::StrCat(path_, ": VIDIOC_ENUM_FMT lists more than ",
                                          kMaxEnumerated, " formats"));
}

absl::StatusOr<std::vector<ControlDescription>> V4l2Device::EnumerateControls() {
  std::vector<ControlDescription> controls;
  uint32_t id = 0;
  for (int n = 0; n < kMaxEnumerated; ++n) {
    v4l2_query_ext_ctrl query{};
    query.id = id | V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
    if (Ioctl(VIDIOC_QUERY_EXT_CTRL, &query) != 0) {
      if (errno == EINVAL) return controls;
      return IoctlError("VIDIOC_QUERY_EXT_CTRL", errno);
    }
    if (query.id <= id) {
      return absl::InternalError(absl::StrFormat(
          "%s: VIDIOC_QUERY_EXT_CTRL went back from control 0x%08x to 0x%08x", path_, id, query.id));
    }
    id = query.id;
    if ((query.flags & V4L2_CTRL_FLAG_DISABLED) != 0) continue;
    if (query.type == V4L2_CTRL_TYPE_CTRL_CLASS) continue;  // a class heading, not a control
    ControlDescription control;
    control.id = query.id;
    control.name = FieldText(query.name);
    control.type = query.type;
    control.minimum = query.minimum;
    control.maximum = query.maximum;
    control.step = query.step;
    control.default_value = query.default_value;
    control.elements = query.nr_of_dims > 0 ? query.dims[0] : 1;
    control.flags = query.flags;
    controls.push_back(std::move(control));
  }
  return absl::InternalError(absl::StrCat(path_, ": VIDIOC_QUERY_EXT_CTRL lists more than ",
                                          kMaxEnumerated, " controls"));
}

}  // namespace transient::v4l2

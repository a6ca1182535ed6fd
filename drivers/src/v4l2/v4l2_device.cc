// A V4L2 device node through ioctl (v4l2_device.h).
#include "v4l2/v4l2_device.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "v4l2/frame_unpacker.h"

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
  for (const ProposedControl& proposed : kProposedControls) {
    if (control.id == proposed.id || control.name == proposed.name) return true;
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

std::string DescribeControlValue(const ControlDescription& control,
                                 std::span<const int64_t> values) {
  if (control.type == V4L2_CTRL_TYPE_BUTTON) return absl::StrCat("'", control.name, "' pressed");
  return absl::StrCat("'", control.name, "' = ", absl::StrJoin(values, ","));
}

namespace {

// A buffer's timestamp in nanoseconds, saturated at int64's ends: a driver may report any
// seconds, and 2^63 ns is 292 years.
int64_t TimevalNanoseconds(const timeval& time) {
  int64_t seconds_ns = 0, nanoseconds = 0;
  if (__builtin_mul_overflow(int64_t{time.tv_sec}, int64_t{1'000'000'000}, &seconds_ns) ||
      __builtin_mul_overflow(int64_t{time.tv_usec}, int64_t{1000}, &nanoseconds) ||
      __builtin_add_overflow(seconds_ns, nanoseconds, &seconds_ns)) {
    return time.tv_sec < 0 ? INT64_MIN : INT64_MAX;
  }
  return seconds_ns;
}

// Array controls (U8/U16/U32, the ToF controls) carry their elements behind a pointer;
// the others in value / value64.
size_t ElementBytes(const ControlDescription& control) {
  switch (control.type) {
    case V4L2_CTRL_TYPE_U8:
      return 1;
    case V4L2_CTRL_TYPE_U16:
      return 2;
    case V4L2_CTRL_TYPE_U32:
      return 4;
    default:
      return 0;
  }
}

int64_t ReadElement(const std::vector<uint8_t>& payload, size_t element_bytes, size_t i) {
  const uint8_t* at = payload.data() + i * element_bytes;
  if (element_bytes == 1) return *at;
  if (element_bytes == 2) {
    uint16_t value;
    std::memcpy(&value, at, 2);
    return value;
  }
  uint32_t value;
  std::memcpy(&value, at, 4);
  return value;
}

void WriteElement(std::vector<uint8_t>& payload, size_t element_bytes, size_t i, int64_t value) {
  uint8_t* at = payload.data() + i * element_bytes;
  if (element_bytes == 1) {
    *at = static_cast<uint8_t>(value);
  } else if (element_bytes == 2) {
    const auto v = static_cast<uint16_t>(value);
    std::memcpy(at, &v, 2);
  } else {
    const auto v = static_cast<uint32_t>(value);
    std::memcpy(at, &v, 4);
  }
}

}  // namespace

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
    : fd_(std::exchange(other.fd_, -1)),
      path_(std::move(other.path_)),
      format_(other.format_),
      mappings_(std::move(other.mappings_)),
      streaming_(std::exchange(other.streaming_, false)) {
  other.mappings_.clear();
}

V4l2Device& V4l2Device::operator=(V4l2Device&& other) noexcept {
  if (this != &other) {
    (void)StopStreaming();
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
    format_ = other.format_;
    mappings_ = std::move(other.mappings_);
    other.mappings_.clear();
    streaming_ = std::exchange(other.streaming_, false);
  }
  return *this;
}

V4l2Device::~V4l2Device() {
  (void)StopStreaming();
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

absl::Status V4l2Device::SetControls(std::span<const ControlValue> values) {
  std::vector<v4l2_ext_control> controls(values.size());
  std::vector<std::vector<uint8_t>> payloads(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    const ControlDescription& control = *values[i].control;
    const std::vector<int64_t>& elements = values[i].values;
    v4l2_ext_control& c = controls[i];
    c.id = control.id;
    const size_t element_bytes = ElementBytes(control);
    if (element_bytes > 0) {
      if (elements.empty() || elements.size() > std::max<uint32_t>(control.elements, 1)) {
        return absl::InvalidArgumentError(absl::StrCat(
            path_, ": ", DescribeControlValue(control, elements), ": the control holds 1 to ",
            std::max<uint32_t>(control.elements, 1), " elements"));
      }
      payloads[i].resize(elements.size() * element_bytes);
      for (size_t e = 0; e < elements.size(); ++e) {
        WriteElement(payloads[i], element_bytes, e, elements[e]);
      }
      c.size = static_cast<uint32_t>(payloads[i].size());
      c.ptr = payloads[i].data();
    } else if (control.type == V4L2_CTRL_TYPE_INTEGER64) {
      c.value64 = elements.empty() ? 0 : elements[0];
    } else {
      c.value = elements.empty() ? 0 : static_cast<int32_t>(elements[0]);
    }
  }
  v4l2_ext_controls request{};
  request.which = V4L2_CTRL_WHICH_CUR_VAL;
  request.count = static_cast<uint32_t>(controls.size());
  request.controls = controls.data();
  if (Ioctl(VIDIOC_S_EXT_CTRLS, &request) == 0) return absl::OkStatus();
  const int error = errno;
  if (error == ENODEV) return IoctlError("VIDIOC_S_EXT_CTRLS", error);
  std::string which;
  if (request.error_idx < values.size()) {
    which = DescribeControlValue(*values[request.error_idx].control,
                                 values[request.error_idx].values);
  } else {
    std::vector<std::string> all;
    for (const ControlValue& value : values) {
      all.push_back(DescribeControlValue(*value.control, value.values));
    }
    which = absl::StrJoin(all, ", ");
  }
  return absl::InvalidArgumentError(absl::StrCat(path_, ": VIDIOC_S_EXT_CTRLS ", which,
                                                 ": the driver refused it (",
                                                 std::strerror(error), ")"));
}

absl::StatusOr<std::vector<int64_t>> V4l2Device::GetControl(const ControlDescription& control) {
  const ControlDescription* one[] = {&control};
  absl::StatusOr<std::vector<std::vector<int64_t>>> values = GetControls(one);
  if (!values.ok()) return values.status();
  return std::move(values->front());
}

absl::StatusOr<std::vector<std::vector<int64_t>>> V4l2Device::GetControls(
    std::span<const ControlDescription* const> wanted) {
  std::vector<v4l2_ext_control> controls(wanted.size());
  std::vector<std::vector<uint8_t>> payloads(wanted.size());
  for (size_t i = 0; i < wanted.size(); ++i) {
    controls[i].id = wanted[i]->id;
    const size_t element_bytes = ElementBytes(*wanted[i]);
    if (element_bytes > 0) {
      payloads[i].resize(std::max<uint32_t>(wanted[i]->elements, 1) * element_bytes);
      controls[i].size = static_cast<uint32_t>(payloads[i].size());
      controls[i].ptr = payloads[i].data();
    }
  }
  v4l2_ext_controls request{};
  request.which = V4L2_CTRL_WHICH_CUR_VAL;
  request.count = static_cast<uint32_t>(controls.size());
  request.controls = controls.data();
  if (Ioctl(VIDIOC_G_EXT_CTRLS, &request) != 0) {
    const int error = errno;
    const std::string which = request.error_idx < wanted.size()
                                  ? absl::StrCat(" '", wanted[request.error_idx]->name, "'")
                                  : "";
    return IoctlError(absl::StrCat("VIDIOC_G_EXT_CTRLS", which).c_str(), error);
  }
  std::vector<std::vector<int64_t>> values(wanted.size());
  for (size_t i = 0; i < wanted.size(); ++i) {
    const ControlDescription& control = *wanted[i];
    const v4l2_ext_control& c = controls[i];
    const size_t element_bytes = ElementBytes(control);
    if (element_bytes == 0) {
      values[i].push_back(control.type == V4L2_CTRL_TYPE_INTEGER64 ? c.value64 : c.value);
      continue;
    }
    if (c.size > payloads[i].size() || c.size % element_bytes != 0) {
      return absl::InternalError(absl::StrCat(path_, ": VIDIOC_G_EXT_CTRLS '", control.name,
                                              "' returned ", c.size, " bytes for at most ",
                                              payloads[i].size()));
    }
    for (size_t e = 0; e < c.size / element_bytes; ++e) {
      values[i].push_back(ReadElement(payloads[i], element_bytes, e));
    }
  }
  return values;
}

absl::Status V4l2Device::SubscribeControlEvents(std::span<const uint32_t> ids) {
  for (uint32_t id : ids) {
    v4l2_event_subscription subscription{};
    subscription.type = V4L2_EVENT_CTRL;
    subscription.id = id;
    if (Ioctl(VIDIOC_SUBSCRIBE_EVENT, &subscription) != 0) {
      const int error = errno;
      if (error == ENOTTY || error == EINVAL) {
        return absl::UnimplementedError(
            absl::StrFormat("%s: no control events for 0x%08x (%s)", path_, id, std::strerror(error)));
      }
      return IoctlError("VIDIOC_SUBSCRIBE_EVENT", error);
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<uint32_t>> V4l2Device::ChangedControls() {
  std::vector<uint32_t> changed;
  for (int n = 0; n < kMaxEnumerated; ++n) {
    v4l2_event event{};
    if (Ioctl(VIDIOC_DQEVENT, &event) != 0) {
      if (errno == ENOENT) return changed;  // none pending
      return IoctlError("VIDIOC_DQEVENT", errno);
    }
    if (event.type == V4L2_EVENT_CTRL && (event.u.ctrl.changes & V4L2_EVENT_CTRL_CH_VALUE) != 0) {
      changed.push_back(event.id);
    }
    if (event.pending == 0) return changed;
  }
  return changed;
}

absl::StatusOr<NegotiatedFormat> V4l2Device::SetFormat(uint32_t fourcc, ImageGeometry geometry) {
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  format.fmt.pix.pixelformat = fourcc;
  format.fmt.pix.width = static_cast<uint32_t>(geometry.width);
  format.fmt.pix.height = static_cast<uint32_t>(geometry.height);
  format.fmt.pix.field = V4L2_FIELD_NONE;
  if (Ioctl(VIDIOC_S_FMT, &format) != 0) return IoctlError("VIDIOC_S_FMT", errno);
  const v4l2_pix_format& granted = format.fmt.pix;
  if (granted.pixelformat != fourcc || static_cast<int>(granted.width) != geometry.width ||
      static_cast<int>(granted.height) != geometry.height) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: asked for %s %dx%d, the driver granted %s %ux%u", path_, FourccName(fourcc),
        geometry.width, geometry.height, FourccName(granted.pixelformat), granted.width,
        granted.height));
  }
  NegotiatedFormat result;
  result.fourcc = granted.pixelformat;
  result.geometry = geometry;
  result.bytes_per_line = granted.bytesperline;
  result.image_bytes = granted.sizeimage;
  absl::StatusOr<size_t> row = RowBytes(fourcc, geometry.width);
  if (!row.ok()) return row.status();
  // Drivers of packed formats may leave bytesperline 0; the packed row is the stride then.
  if (result.bytes_per_line == 0) result.bytes_per_line = *row;
  const size_t needed = result.bytes_per_line * static_cast<size_t>(geometry.height - 1) + *row;
  if (result.bytes_per_line < *row || result.image_bytes < needed) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: the driver's layout for %s %dx%d (%zu bytes per line, %zu per image) is too small "
        "for its samples (%zu per row, %zu per image)",
        path_, FourccName(fourcc), geometry.width, geometry.height, result.bytes_per_line,
        result.image_bytes, *row, needed));
  }
  format_ = result;
  return result;
}

void V4l2Device::Unmap() {
  for (const Mapping& mapping : mappings_) ::munmap(mapping.address, mapping.length);
  mappings_.clear();
}

absl::Status V4l2Device::StartStreaming(int buffers, int minimum_buffers) {
  if (format_.image_bytes == 0) {
    return absl::FailedPreconditionError(absl::StrCat(path_, ": no format set before streaming"));
  }
  if (streaming_) return absl::OkStatus();
  v4l2_requestbuffers request{};
  request.count = static_cast<uint32_t>(buffers);
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  if (Ioctl(VIDIOC_REQBUFS, &request) != 0) return IoctlError("VIDIOC_REQBUFS", errno);
  if (static_cast<int>(request.count) < minimum_buffers) {
    v4l2_requestbuffers release{};
    release.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    release.memory = V4L2_MEMORY_MMAP;
    (void)Ioctl(VIDIOC_REQBUFS, &release);
    return absl::FailedPreconditionError(
        absl::StrCat(path_, ": the driver granted ", request.count, " buffers, ",
                     minimum_buffers, " are needed to queue a whole sequence"));
  }
  for (uint32_t index = 0; index < request.count; ++index) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    buffer.index = index;
    absl::Status failure;
    if (Ioctl(VIDIOC_QUERYBUF, &buffer) != 0) {
      failure = IoctlError("VIDIOC_QUERYBUF", errno);
    } else if (buffer.length < format_.image_bytes) {
      failure = absl::FailedPreconditionError(absl::StrCat(
          path_, ": buffer ", index, " holds ", buffer.length, " bytes, an image ",
          format_.image_bytes));
    } else {
      void* address = ::mmap(nullptr, buffer.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_,
                             buffer.m.offset);
      if (address == MAP_FAILED) {
        failure = absl::InternalError(
            absl::StrCat(path_, ": mmap of buffer ", index, ": ", std::strerror(errno)));
      } else {
        mappings_.push_back({address, buffer.length});
        if (Ioctl(VIDIOC_QBUF, &buffer) != 0) failure = IoctlError("VIDIOC_QBUF", errno);
      }
    }
    if (!failure.ok()) {
      streaming_ = true;  // so that StopStreaming releases what was set up
      (void)StopStreaming();
      return failure;
    }
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (Ioctl(VIDIOC_STREAMON, &type) != 0) {
    const absl::Status failure = IoctlError("VIDIOC_STREAMON", errno);
    streaming_ = true;
    (void)StopStreaming();
    return failure;
  }
  streaming_ = true;
  return absl::OkStatus();
}

absl::StatusOr<DequeuedFrame> V4l2Device::Dequeue(absl::Duration timeout) {
  if (!streaming_) return absl::FailedPreconditionError(absl::StrCat(path_, ": not streaming"));
  const absl::Time deadline = absl::Now() + timeout;
  while (true) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    if (Ioctl(VIDIOC_DQBUF, &buffer) == 0) {
      if (buffer.index >= mappings_.size()) {
        return absl::InternalError(absl::StrCat(path_, ": VIDIOC_DQBUF returned buffer ",
                                                buffer.index, " of ", mappings_.size()));
      }
      const Mapping& mapping = mappings_[buffer.index];
      DequeuedFrame frame;
      frame.index = static_cast<int>(buffer.index);
      frame.buffer.sequence = buffer.sequence;
      frame.buffer.timestamp_ns = TimevalNanoseconds(buffer.timestamp);
      frame.buffer.error_flag = (buffer.flags & V4L2_BUF_FLAG_ERROR) != 0;
      frame.buffer.bytes_used = buffer.bytesused;
      frame.data = std::span<const uint8_t>(static_cast<const uint8_t*>(mapping.address),
                                            std::min<size_t>(buffer.bytesused, mapping.length));
      return frame;
    }
    const int error = errno;
    if (error != EAGAIN) {
      if (error == ENODEV) {
        return absl::UnavailableError(absl::StrCat(path_, ": VIDIOC_DQBUF: device gone"));
      }
      return IoctlError("VIDIOC_DQBUF", error);
    }
    const absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration()) {
      return absl::DeadlineExceededError(
          absl::StrCat(path_, ": no buffer within ", absl::FormatDuration(timeout)));
    }
    pollfd poll_fd{.fd = fd_, .events = POLLIN, .revents = 0};
    const int ready = ::poll(&poll_fd, 1, static_cast<int>(absl::ToInt64Milliseconds(left)) + 1);
    if (ready > 0) {
      // A node whose poll is always ready (an emulated one) must not spin: a short pause.
      absl::SleepFor(std::min(left, absl::Milliseconds(1)));
    }
  }
}

absl::Status V4l2Device::Requeue(int index) {
  if (!streaming_ || index < 0 || static_cast<size_t>(index) >= mappings_.size()) {
    return absl::FailedPreconditionError(absl::StrCat(path_, ": cannot requeue buffer ", index));
  }
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.index = static_cast<uint32_t>(index);
  if (Ioctl(VIDIOC_QBUF, &buffer) != 0) return IoctlError("VIDIOC_QBUF", errno);
  return absl::OkStatus();
}

absl::Status V4l2Device::StopStreaming() {
  if (!streaming_) return absl::OkStatus();
  streaming_ = false;
  absl::Status result;
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (Ioctl(VIDIOC_STREAMOFF, &type) != 0 && errno != ENODEV) {
    result = IoctlError("VIDIOC_STREAMOFF", errno);
  }
  Unmap();
  v4l2_requestbuffers release{};
  release.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  release.memory = V4L2_MEMORY_MMAP;
  if (Ioctl(VIDIOC_REQBUFS, &release) != 0 && errno != ENODEV && result.ok()) {
    result = IoctlError("VIDIOC_REQBUFS 0", errno);
  }
  return result;
}

}  // namespace transient::v4l2

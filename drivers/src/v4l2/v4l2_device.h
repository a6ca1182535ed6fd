// A V4L2 device node through the kernel's ioctl interface (linux/videodev2.h): open, the
// capabilities, the pixel formats and the controls. Thin RAII over libc open/ioctl (not
// syscall(), so that umockdev can stand in for the kernel in tests), EINTR retried
// (../shared/research/v4l2.md §2.1, §2.2, §2.5, §5.1).
#pragma once

#include <linux/videodev2.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "transient/reconstruct/image.h"
#include "v4l2/sequence_assembler.h"

namespace transient::v4l2 {

struct Capabilities {
  std::string driver;    // v4l2_capability.driver, e.g. "mlx7502x"
  std::string card;      // the device's name
  std::string bus_info;
  uint32_t device_caps = 0;  // of this node (capabilities when the driver has no device_caps)
  bool capture() const;      // single- or multi-planar video capture
  bool streaming() const;
};

struct PixelFormatDescription {
  uint32_t fourcc = 0;
  std::string description;  // the driver's, e.g. "12-bit Greyscale (MIPI Packed)"
};

struct ControlDescription {
  uint32_t id = 0;
  std::string name;  // e.g. "TOF Phase Sequence"
  uint32_t type = 0;  // V4L2_CTRL_TYPE_*
  int64_t minimum = 0, maximum = 0, default_value = 0;
  uint64_t step = 0;
  uint32_t elements = 1;  // dims[0] for arrays (the maximum length of a dynamic array)
  uint32_t flags = 0;     // V4L2_CTRL_FLAG_*
  bool dynamic_array() const;
};

// The proposed ToF control class (V4L2_CTRL_CLASS_TOF, mlx7502x patch v6; not in Debian 12's
// kernel headers) and the camera trigger controls of the same series, each with the name drivers
// give it (its ID moved between patch versions, its name did not) and its type.
struct ProposedControl {
  uint32_t id;
  const char* name;
  uint32_t type;  // V4L2_CTRL_TYPE_*
};
constexpr uint32_t kTofControlClass = 0x00a60000;
constexpr ProposedControl kTofPhaseSequence = {0x00a60900, "TOF Phase Sequence",
                                               V4L2_CTRL_TYPE_U16};
constexpr ProposedControl kTofFrequencyModulation = {0x00a60901, "TOF Frequency Modulation",
                                                     V4L2_CTRL_TYPE_U32};
constexpr ProposedControl kTofTimeIntegration = {0x00a60902, "TOF Time Integration",
                                                 V4L2_CTRL_TYPE_U16};
constexpr ProposedControl kCameraTrigger = {0x009a0925, "Camera Trigger", V4L2_CTRL_TYPE_BUTTON};
constexpr ProposedControl kCameraTriggerMode = {0x009a0926, "Camera Trigger Mode",
                                                V4L2_CTRL_TYPE_MENU};
constexpr ProposedControl kProposedControls[] = {kTofPhaseSequence, kTofFrequencyModulation,
                                                 kTofTimeIntegration, kCameraTrigger,
                                                 kCameraTriggerMode};

// A control of the ToF class or a trigger control, by ID or (IDs moved between patch versions)
// by name.
bool IsTofControl(const ControlDescription& control);
// "u16[8] 0..315 step 45", "menu 0..2", "button", ...
std::string DescribeControlRange(const ControlDescription& control);

// Elements of a control to set: one for a scalar or a one-element array, the array's for an
// array (a dynamic array takes its length from them), none for a button.
struct ControlValue {
  const ControlDescription* control = nullptr;
  std::vector<int64_t> values;
};

// "'TOF Phase Sequence' = 0,90,180,270" for messages.
std::string DescribeControlValue(const ControlDescription& control,
                                 std::span<const int64_t> values);

// The format the driver agreed to (VIDIOC_S_FMT's read-back).
struct NegotiatedFormat {
  uint32_t fourcc = 0;
  ImageGeometry geometry;
  size_t bytes_per_line = 0;
  size_t image_bytes = 0;  // sizeimage: what bytesused of a whole buffer is
};

// A dequeued buffer: what the driver said of it, and its bytes (valid until it is requeued).
struct DequeuedFrame {
  int index = -1;
  DequeuedBuffer buffer;
  std::span<const uint8_t> data;  // the mapping, bytesused long (at most the buffer's length)
};

class V4l2Device {
 public:
  // Opens `path` read-write, non-blocking. NotFound, PermissionDenied, Unavailable (busy or
  // gone) or FailedPrecondition (not a character device), each naming the path.
  static absl::StatusOr<V4l2Device> Open(const std::string& path);

  V4l2Device(V4l2Device&& other) noexcept;
  V4l2Device& operator=(V4l2Device&& other) noexcept;
  V4l2Device(const V4l2Device&) = delete;
  V4l2Device& operator=(const V4l2Device&) = delete;
  ~V4l2Device();

  const std::string& path() const { return path_; }

  // VIDIOC_QUERYCAP. An error names the path and the errno (ENOTTY: not a V4L2 node).
  absl::StatusOr<Capabilities> QueryCapabilities();
  // VIDIOC_ENUM_FMT for single-planar capture until the driver says EINVAL.
  absl::StatusOr<std::vector<PixelFormatDescription>> EnumerateFormats();
  // VIDIOC_QUERY_EXT_CTRL with NEXT_CTRL | NEXT_COMPOUND until EINVAL; disabled ones skipped.
  absl::StatusOr<std::vector<ControlDescription>> EnumerateControls();

  // VIDIOC_S_EXT_CTRLS of `values` in one call (the driver applies all or none).
  // InvalidArgument naming the control the driver refused (its error_idx), the value and the
  // errno; Unavailable when the device is gone.
  absl::Status SetControls(std::span<const ControlValue> values);
  // VIDIOC_G_EXT_CTRLS of one control: its current elements (a dynamic array's current length).
  absl::StatusOr<std::vector<int64_t>> GetControl(const ControlDescription& control);
  // VIDIOC_G_EXT_CTRLS of several controls in one call: their elements, in order.
  absl::StatusOr<std::vector<std::vector<int64_t>>> GetControls(
      std::span<const ControlDescription* const> controls);

  // VIDIOC_SUBSCRIBE_EVENT to value changes of `ids` (V4L2_EVENT_CTRL) made by other programs
  // (the kernel does not tell a file handle of its own changes). Unimplemented when the driver
  // has no control events.
  absl::Status SubscribeControlEvents(std::span<const uint32_t> ids);
  // VIDIOC_DQEVENT until none is pending: the controls whose value changed, in order. Empty
  // when none did.
  absl::StatusOr<std::vector<uint32_t>> ChangedControls();

  // VIDIOC_S_FMT for single-planar capture. A driver that grants another pixel format or size
  // is refused: InvalidArgument naming what was asked and what was granted.
  absl::StatusOr<NegotiatedFormat> SetFormat(uint32_t fourcc, ImageGeometry geometry);

  // REQBUFS (memory-mapped) with `buffers`, QUERYBUF and mmap of each, QBUF of all, STREAMON.
  // FailedPrecondition when the driver grants fewer than `minimum_buffers` or a buffer shorter
  // than the format's image; errors name the ioctl and the errno. Needs SetFormat first.
  absl::Status StartStreaming(int buffers, int minimum_buffers);
  // VIDIOC_DQBUF, waiting up to `timeout` (poll, then retrying on EAGAIN: an emulated node's
  // poll is always ready). DeadlineExceeded when nothing came, Unavailable when the device is
  // gone (ENODEV), Internal for EIO and other errors, each naming the errno.
  absl::StatusOr<DequeuedFrame> Dequeue(absl::Duration timeout);
  // VIDIOC_QBUF of a dequeued buffer.
  absl::Status Requeue(int index);
  // STREAMOFF, munmap, REQBUFS 0; also done by the destructor. Idempotent.
  absl::Status StopStreaming();
  bool streaming() const { return streaming_; }

 private:
  struct Mapping {
    void* address = nullptr;
    size_t length = 0;
  };

  V4l2Device(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  void Unmap();
  // ioctl(2), retried on EINTR; -1 with errno set on failure.
  int Ioctl(unsigned long request, void* argument) const;
  absl::Status IoctlError(const char* what, int error) const;

  int fd_ = -1;
  std::string path_;
  NegotiatedFormat format_;
  std::vector<Mapping> mappings_;
  bool streaming_ = false;
};

}  // namespace transient::v4l2

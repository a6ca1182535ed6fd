// An emulated V4L2 ToF sensor for tests: umockdev (Debian's 0.17) creates /dev/videoN nodes in
// this process and answers their ioctls with the handler here, which plays the kernel side as
// the V4L2 API and the proposed mlx7502x driver document it (../shared/research/v4l2.md §1.1,
// §2, §3.1). The code under test opens and ioctls /dev/videoN unchanged; the test binary runs
// with LD_PRELOAD=libumockdev-preload.so.0 (ctest sets it). Streaming: the node's buffers are
// regions of the regular file behind it, which the code under test mmaps; a dequeue writes the
// next frame the test pushed into a queued buffer (research §3.1: poll is always ready there).
// Not emulated yet: setting controls, trigger and events.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "transient/reconstruct/image.h"
#include "v4l2/v4l2_device.h"

namespace transient::v4l2::testing {

struct EmulatedFormat {
  uint32_t fourcc;
  std::string description;
};

// One node's behaviour.
struct EmulatedNode {
  std::string name = "video0";          // /dev/<name>
  std::string driver = "mlx7502x";
  std::string card = "MLX75027 ToF";
  std::string bus_info = "platform:emulated";
  uint32_t device_caps = 0x04000001;    // V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING
  int querycap_errno = 0;               // nonzero: VIDIOC_QUERYCAP fails with it
  std::vector<EmulatedFormat> formats;  // VIDIOC_ENUM_FMT, in order
  std::vector<ControlDescription> controls;  // VIDIOC_QUERY_EXT_CTRL, ascending IDs
  ImageGeometry sensor = {640, 480};    // the only size VIDIOC_S_FMT grants (it adjusts to it)
  size_t row_padding = 0;               // bytesperline = the format's packed row + this
  int max_buffers = 8;                  // VIDIOC_REQBUFS clamps to it
};

// One frame the sensor delivers at the next VIDIOC_DQBUF.
struct EmulatedFrame {
  std::vector<uint8_t> bytes;       // written into the buffer; bytesused = its size
  bool error_flag = false;          // V4L2_BUF_FLAG_ERROR
  uint32_t frames_lost_before = 0;  // the driver's sequence skips this many first
  int64_t timestamp_ns = 0;         // CLOCK_MONOTONIC
};

// The controls of the mlx7502x patch v6 on its subdevice, with their documented types, ranges
// and dimensions (research §1.1), plus a vendor control.
std::vector<ControlDescription> Mlx7502xControls();

class EmulatedTofSensor {
 public:
  EmulatedTofSensor();
  ~EmulatedTofSensor();
  EmulatedTofSensor(const EmulatedTofSensor&) = delete;
  EmulatedTofSensor& operator=(const EmulatedTofSensor&) = delete;

  // Whether this process runs under umockdev's preload library (else nothing is emulated).
  static bool Available();

  // Adds /dev/<node.name> (a character device 81:N) answering as `node` says.
  void AddNode(const EmulatedNode& node);
  // Queues a frame for the node's next dequeue.
  void PushFrame(const std::string& name, EmulatedFrame frame);
  // The device goes away: every ioctl of the node fails with ENODEV from now on.
  void Unplug(const std::string& name);

  struct State;  // the nodes and the kernel side's state (emulated_tof_sensor.cc)

 private:
  std::unique_ptr<State> state_;
};

}  // namespace transient::v4l2::testing

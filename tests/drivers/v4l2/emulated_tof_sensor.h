// An emulated V4L2 ToF sensor for tests: umockdev (Debian's 0.17) creates /dev/videoN nodes in
// this process and answers their ioctls with the handler here, which plays the kernel side as
// the V4L2 API and the proposed mlx7502x driver document it (../shared/research/v4l2.md §1.1,
// §2, §3.1). The code under test opens and ioctls /dev/videoN unchanged; the test binary runs
// with LD_PRELOAD=libumockdev-preload.so.0 (ctest sets it). Not emulated here yet: formats,
// buffers and streaming (the capture source's part of the work).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

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

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace transient::v4l2::testing

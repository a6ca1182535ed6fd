// An emulated V4L2 ToF sensor for tests: umockdev (Debian's 0.17) creates /dev/videoN nodes in
// this process and answers their ioctls with the handler here, which plays the kernel side as
// the V4L2 API and the proposed mlx7502x driver document it (../shared/research/v4l2.md §1.1,
// §2, §3.1). The code under test opens and ioctls /dev/videoN unchanged; the test binary runs
// with LD_PRELOAD=libumockdev-preload.so.0 (ctest sets it).
//
// What the kernel side does:
//  * capabilities, formats (VIDIOC_S_FMT adjusts what the node cannot do), buffers: the node's
//    buffers are regions of the regular file behind it, which the code under test mmaps;
//  * controls: VIDIOC_QUERY_EXT_CTRL, G/S_EXT_CTRLS with the V4L2 core's rules (integer
//    elements clamped to the range and rounded to the step, a dynamic array's length from the
//    caller's size, all or nothing, error_idx naming the refused control), on the node itself
//    or, like the mlx7502x, on a separate subdevice node (`controls_on`);
//  * frames: the test pushes them (PushFrame), or a renderer draws each phase sequence for the
//    controls' current values: one sequence per press of the Camera Trigger button in
//    internal-trigger mode (mode 1), or one after another in continuous mode (0). Each frame's
//    samples are packed into the negotiated container as the kernel's pixfmt pages describe;
//  * control events: VIDIOC_SUBSCRIBE_EVENT / VIDIOC_DQEVENT of V4L2_EVENT_CTRL for changes made
//    by someone else (SetControl, the kControlChanged fault), not by the code under test;
//  * faults by sequence: an error-flagged, short or lost buffer, a stall, an unplug, a control
//    changed by someone else while the sequence is read out.
// Not emulated (umockdev cannot, research §3.1): poll readiness (always ready, so POLLPRI does
// not announce events: the code under test asks with DQEVENT), fstat of the fd, DMABUF.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
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

// What the sensor is programmed to take when a sequence starts: the controls' current values.
struct ProgrammedSequence {
  int64_t index = 0;                // sequences started on this node so far, from 0
  double frequency_hz = 0.0;        // TOF Frequency Modulation[0]
  std::vector<int64_t> phases_deg;  // TOF Phase Sequence: one frame per element
  std::vector<int64_t> integration_us;  // TOF Time Integration (per phase; the last repeats)
};

// The samples of one sequence's frames, row-major, in sensor codes (negative for signed A-B
// output; packed as two's complement in the container's bits).
using Renderer = std::function<std::vector<std::vector<int32_t>>(const ProgrammedSequence&,
                                                                 ImageGeometry)>;

// A fault the sensor injects into the sequence with this index.
struct SequenceFault {
  enum Kind {
    kErrorFlag,         // frame `frame` is flagged V4L2_BUF_FLAG_ERROR
    kShortFrame,        // frame `frame` comes with half its bytes
    kLostFrame,         // frame `frame` is never delivered (the driver's sequence skips it)
    kStall,             // the sequence never comes
    kUnplug,            // the device goes away instead of this sequence
    kControlChanged,    // someone sets TOF Frequency Modulation to `value` after the sequence's
                        // frames are taken, before they are all read
  };
  int64_t sequence = 0;
  Kind kind = kErrorFlag;
  int frame = 0;
  int64_t value = 0;
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
  // The node whose controls program this node's frames ("" = this node; "v4l-subdev0" for a
  // sensor whose controls live on its subdevice, like the mlx7502x). A trigger pressed there
  // starts a sequence here.
  std::string controls_on;
  ImageGeometry sensor = {640, 480};    // the only size VIDIOC_S_FMT grants (it adjusts to it)
  size_t row_padding = 0;               // bytesperline = the format's packed row + this
  int max_buffers = 8;                  // VIDIOC_REQBUFS clamps to it
  int sample_bits = 12;                 // how many low bits of a sample the container holds
  Renderer renderer;                    // draws sequences; none: only pushed frames come
  // The sensor's clock (CLOCK_MONOTONIC ns of its buffers): a frame every `frame_ns` inside a
  // sequence, and `idle_ns` more before a sequence starts.
  int64_t frame_ns = 1'500'000;
  int64_t idle_ns = 20'000'000;
  // Deliver at the sensor's pace: a frame no sooner after the previous one than their
  // timestamps differ (else as fast as they are asked for).
  bool realtime = false;
  uint32_t refuse_control = 0;  // S_EXT_CTRLS of this control ID fails with EINVAL
  bool events = true;           // false: VIDIOC_SUBSCRIBE_EVENT fails with ENOTTY
};

// One frame the sensor delivers at the next VIDIOC_DQBUF.
struct EmulatedFrame {
  std::vector<uint8_t> bytes;       // written into the buffer; bytesused = its size
  bool error_flag = false;          // V4L2_BUF_FLAG_ERROR
  uint32_t frames_lost_before = 0;  // the driver's sequence skips this many first
  int64_t timestamp_ns = 0;         // CLOCK_MONOTONIC
};

// The controls of the mlx7502x patch v6 on its subdevice, with their documented types, ranges
// and dimensions (research §1.1), plus a vendor control. `tof_base` moves the three ToF
// controls to other IDs (an earlier patch version's private IDs), keeping their names.
std::vector<ControlDescription> Mlx7502xControls(uint32_t tof_base = 0x00a60900);

// Packs `samples` (row-major, `geometry`) into a buffer of `fourcc` with `bytes_per_line`, as
// the kernel's pixfmt pages lay them out: 16-bit little-endian words (Y12, BG12, Y16) or MIPI
// RAW12 pairs (Y12P, pBCC); negative samples as two's complement in `bits` bits.
std::vector<uint8_t> PackSamples(uint32_t fourcc, ImageGeometry geometry, size_t bytes_per_line,
                                 int bits, const std::vector<int32_t>& samples);

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
  // Faults for the node's rendered sequences.
  void InjectFault(const std::string& name, SequenceFault fault);
  // The device goes away: every ioctl of the node fails with ENODEV from now on.
  void Unplug(const std::string& name);
  // It comes back as a fresh device: no format, buffers or stream; controls kept.
  void Replug(const std::string& name);
  // Someone else sets a control of the node (as another program's VIDIOC_S_EXT_CTRLS would,
  // with an event to the subscribers).
  void SetControl(const std::string& name, uint32_t id, std::vector<int64_t> values);
  std::vector<int64_t> Control(const std::string& name, uint32_t id);
  // Sequences the node's renderer has started.
  int64_t SequencesStarted(const std::string& name);

  struct State;  // the nodes and the kernel side's state (emulated_tof_sensor.cc)

 private:
  std::unique_ptr<State> state_;
};

}  // namespace transient::v4l2::testing

// An emulated Kinect v2 for tests: umockdev (Debian's 0.17) adds a USB device to the testbed
// of this process and answers the usbdevfs ioctls of its /dev/bus/usb node with the handler
// here, which plays both the kernel's usbdevfs and the camera as ../shared/research/libusb.md
// §1 documents them. The code under test uses Debian's libusb-1.0.26 unchanged: it enumerates
// the device through udev and sysfs, and submits, reaps and discards URBs on the node. The test
// binary runs with LD_PRELOAD=libumockdev-preload.so.0 (ctest sets it).
//
// Create the emulator BEFORE the code under test calls libusb_init (libusb looks for its usbfs
// directory and starts its udev monitor there), and destroy it after libusb_exit. One emulator
// per process, one process per test case (ctest runs each gtest case on its own).
//
// What the device does:
//  * enumeration: 045e:02d8 (or 02c4), USB 3 (`speed_mbps`), the serial as string descriptor
//    iSerialNumber; configuration 1 with interface 0 (bulk OUT 0x02, bulk IN 0x81 for commands,
//    bulk IN 0x83 for RGB, never served) and interface 1, alt 0 without endpoints and alt 1 with
//    isochronous IN 0x84 and its SuperSpeed companion (wBytesPerInterval 0x8400);
//  * the kernel side: SETCONFIGURATION, CLAIM/RELEASEINTERFACE, SETINTERFACE (a URB for an
//    endpoint that the current alt setting lacks is refused with ENOENT; leaving alt 1 kills
//    the in-flight iso URBs with -ESHUTDOWN), SUBMITURB, REAPURBNDELAY (EAGAIN while nothing
//    is complete), DISCARDURB (the URB comes back with -ENOENT: LIBUSB_TRANSFER_CANCELLED);
//  * standard control requests: GET_DESCRIPTOR (device, configuration, strings), GET_STATUS,
//    GET_CONFIGURATION, SET/CLEAR_FEATURE, SET_SEL, SET_ISOCH_DELAY, SET_INTERFACE; anything
//    else stalls (-EPIPE);
//  * the command protocol (research §1.2): a command on 0x02 queues its response data (at most
//    max_response_length bytes) and then the 16-byte "response complete" on 0x81;
//  * the depth stream (research §1.3, §1.4): at alt 1 with streaming on (0x2B(1)), each iso URB
//    on 0x84 is filled with the next packets of the stream: per sub-frame the 298,496-byte
//    sub-image that the renderer's samples encode to, its 152-byte footer, cut into packets of
//    at most 33,792 bytes, then zero-length packets (one, or in realtime mode the idle
//    intervals that make a frame last 266 x 125 us).
//
// Limits of the emulation, each a fact of umockdev or of this file:
//  * the node is a regular file, so poll() is always ready and libusb busy-polls
//    REAPURBNDELAY; blocking REAPURB answers like REAPURBNDELAY (libusb 1.0.26 never uses it);
//  * a plain file has no POLLERR, so an unplug completes every in-flight URB with -ESHUTDOWN
//    (the kernel's answer to a disconnect, which libusb reports as LIBUSB_TRANSFER_NO_DEVICE)
//    and then answers every ioctl with ENODEV; the device leaves the testbed with a "remove"
//    uevent;
//  * in fast mode (not `realtime`) there is no bus clock: iso URBs stay pending while the
//    camera has nothing to send (streaming off, frame limit reached) instead of
//    completing with empty packets; in realtime mode they complete at the bus's pace with
//    zero-length packets; a host that falls behind delays the stream instead of losing it;
//  * a bulk IN URB takes at most its buffer's length of a response, and the rest waits for the
//    next URB (no babble on a short buffer); an iso packet the host asks smaller than the
//    camera's packet gets its first bytes with -EOVERFLOW (babble);
//  * URB data moves through the client's pointers (in-process, research §5.2), not umockdev's
//    socket, so the emulation runs only inside the process under test.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace transient::kinect2::testing {

// The depth stream's geometry and framing (research §1.3, §1.4).
inline constexpr int kWidth = 512;
inline constexpr int kHeight = 424;
inline constexpr int kSubFramesPerFrame = 10;
inline constexpr size_t kSubImageRowBytes = 704;                       // 512 samples of 11 bits
inline constexpr size_t kSubImageBytes = kSubImageRowBytes * kHeight;  // 298,496
inline constexpr size_t kFooterBytes = 152;
inline constexpr size_t kSubPacketBytes = kSubImageBytes + kFooterBytes;  // 298,648
inline constexpr size_t kMaxIsoPacketBytes = 0x8400;   // 33,792: wBytesPerInterval of 0x84
inline constexpr uint32_t kFooterMagic0 = 0x00000000;  // constants of the emulation (the real
inline constexpr uint32_t kFooterMagic1 = 0x4B324553;  // magics are unknown and never checked)
// Units of the footer timestamp and the frame period in them (30 Hz: 266 x 125 us = 33.25 ms);
// sub-frame k of a frame is stamped frame + k * kSubFrameTicks.
inline constexpr int64_t kTimestampTickNs = 125'000;
inline constexpr uint32_t kFrameTicks = 266;
inline constexpr uint32_t kSubFrameTicks = 26;
inline constexpr uint16_t kSaturationCode = 1024;

// The command protocol (research §1.2).
inline constexpr uint32_t kCommandMagic = 0x06022009;
inline constexpr uint32_t kCompleteMagic = 0x0A6FE000;
inline constexpr size_t kCompleteBytes = 16;
inline constexpr uint32_t kReadFirmwareVersions = 0x02;
inline constexpr uint32_t kInitStreams = 0x09;
inline constexpr uint32_t kStop = 0x0A;
inline constexpr uint32_t kReadHardwareInfo = 0x14;
inline constexpr uint32_t kReadStatus = 0x16;
inline constexpr uint32_t kReadData = 0x22;
inline constexpr uint32_t kSetStreaming = 0x2B;
inline constexpr uint32_t kSetMode = 0x4B;
inline constexpr uint32_t kStatusParam = 0x090000;  // 0x16's parameter: bit 0 = ready
// 0x22's parameter: the data page.
inline constexpr uint32_t kPageSerial = 1;
inline constexpr uint32_t kPageP0Tables = 2;
inline constexpr uint32_t kPageDepthIntrinsics = 3;
inline constexpr uint32_t kPageRgbParams = 4;
// Response sizes: 7 firmware entries of 16 bytes; the P0 tables' 8 x u32 header, three tables
// of 424 x 512 u16 each between two u16 pads, and a 100-byte tail.
inline constexpr size_t kFirmwareResponseBytes = 7 * 16;
inline constexpr size_t kHardwareInfoBytes = 0x5C;
inline constexpr size_t kSerialPageBytes = 0x80;
inline constexpr size_t kDepthIntrinsicsBytes = 23 * 4;
inline constexpr size_t kP0TableOffset = 32 + 2;  // table 0's first sample (after header, pad)
inline constexpr size_t kP0TableStride = 2 + 2 * kWidth * kHeight + 2;   // pad, table, pad
inline constexpr size_t kP0TablesBytes = 32 + 3 * kP0TableStride + 100;  // 1,302,672
inline constexpr size_t kRgbParamsBytes = 0x1C0;

// The 11-bit code of a sample (research §1.4): the nearest companded value (0..255 step 1,
// then steps 2, 4, ..., 64 for 128 codes each up to 16,320); a negative value is 1024 plus the
// code of its magnitude (one that rounds to 0 is code 0); NaN is 0; a magnitude beyond 16,352
// (16,320 by more than half its step) or a value >= 32,767 is the saturation code 1024.
uint16_t EncodeSample(float value);

// One sub-image as the camera sends it: `samples` are kWidth x kHeight values in output image
// order (row 0 at the top, x from the left), row r stored in sub-image row r for r < 212 and in
// row 635 - r below; column x in slot x / 4 + 128 * (x % 4) of its row, whose 11-bit code
// occupies bits 11 * slot .. 11 * slot + 10 of the row read as a little-endian bit stream.
// Precondition: samples.size() == kWidth * kHeight; the first form writes the sub-image's
// kSubImageBytes into `bytes` (bytes.size() >= kSubImageBytes), the second returns them.
void EncodeSubImage(std::span<const float> samples, std::span<uint8_t> bytes);
std::vector<uint8_t> EncodeSubImage(std::span<const float> samples);

// Writes the samples of sub-frame `subframe` (0..9) of depth frame `sequence` into `samples`,
// every one of them: kWidth x kHeight values in output image order (see EncodeSubImage), in a
// buffer the emulator keeps (a sub-frame 300 times a second would otherwise be a fresh 850 KB
// allocation each; under the sanitizers, fresh pages of a large allocation each time). Runs on
// umockdev's thread with the emulator's lock held: it must not call the emulator.
using Renderer = std::function<void(uint32_t sequence, int subframe, std::span<float> samples)>;

// Entry 3 of the firmware versions, printed major.minor.revision.build (4.0.3912.0).
struct FirmwareVersion {
  uint16_t major = 4;
  uint16_t minor = 0;
  uint32_t revision = 3912;
  uint32_t build = 0;
};

// The depth camera's intrinsics as page 3 sends them (pixels; Brown-Conrady distortion).
struct DepthIntrinsics {
  float fx = 365.0f, fy = 365.0f;
  float cx = 256.0f, cy = 212.0f;
  float k1 = 0.09f, k2 = -0.27f, p1 = 0.0f, p2 = 0.0f, k3 = 0.09f;
};

// A fault the device injects.
struct Fault {
  enum Kind {
    // The stream, at (sequence, subframe, packet); `packet` counts the 9 data packets of the
    // sub-frame (0..8):
    kPacketError,        // the packet comes with status -EPROTO and no data (its bytes are lost)
    kShortPacket,        // the packet comes with the first half of its bytes (the rest is lost)
    kZeroLengthPacket,   // a zero-length packet comes before the packet (nothing is lost)
    kLostSubPacket,      // the sub-frame is never sent (only its idle packets are)
    kWrongFooterLength,  // the footer's length field is `value`
    kUnplugStreaming,    // the device goes away when the stream reaches the sub-frame
    // The commands, at the `occurrence`-th time (from 0; kEveryTime) command id `command`
    // arrives:
    kCommandTimeout,   // neither its response nor its "complete" ever comes
    kWrongSequence,    // its "complete" carries sequence + 1
    kUnplugAtCommand,  // the device goes away instead: its SUBMITURB fails (ENODEV), unrecorded
  };
  static constexpr int kEveryTime = -1;

  // kPacketError, kShortPacket, kZeroLengthPacket.
  static Fault AtPacket(Kind kind, uint32_t sequence, int subframe, int packet) {
    Fault fault;
    fault.kind = kind;
    fault.sequence = sequence;
    fault.subframe = subframe;
    fault.packet = packet;
    return fault;
  }
  // kLostSubPacket, kWrongFooterLength (`value`: the length), kUnplugStreaming.
  static Fault AtSubFrame(Kind kind, uint32_t sequence, int subframe, uint32_t value = 0) {
    Fault fault;
    fault.kind = kind;
    fault.sequence = sequence;
    fault.subframe = subframe;
    fault.value = value;
    return fault;
  }
  // kCommandTimeout, kWrongSequence, kUnplugAtCommand.
  static Fault AtCommand(Kind kind, uint32_t command, int occurrence = 0) {
    Fault fault;
    fault.kind = kind;
    fault.command = command;
    fault.occurrence = occurrence;
    return fault;
  }

  Kind kind = kPacketError;
  uint32_t sequence = 0;
  int subframe = 0;
  int packet = 0;
  uint32_t command = 0;
  int occurrence = 0;
  uint32_t value = 0;
};

struct Options {
  uint16_t product_id = 0x02d8;  // 0x02c4: the other ID of the retail units
  int speed_mbps = 5000;         // sysfs `speed`: 5000 SuperSpeed, 480 a USB 2 port
  int busnum = 1;
  int devnum = 2;
  std::string serial = "501234543042";  // ASCII, at most 63 characters
  FirmwareVersion firmware;
  DepthIntrinsics intrinsics;
  // The P0 tables in the order the device sends them (kWidth * kHeight each); empty = zeros.
  std::array<std::vector<uint16_t>, 3> p0_tables;
  // The poll of 0x16 (kStatusParam) that first answers with bit 0 set, from 1; kNever.
  static constexpr int kNever = 0;
  int status_ready_after_polls = 2;
  // Draws the sub-frames; none: every sample is kDefaultSample.
  Renderer renderer;
  static constexpr float kDefaultSample = 100.0f;
  // Sub-frames at the camera's pace (a frame per 33.25 ms, zero-length packets between
  // sub-frames) instead of as fast as the host reaps.
  bool realtime = false;
  int64_t max_frames = 0;        // frames the camera sends, then nothing; 0 = no limit
  uint32_t first_timestamp = 0;  // footer timestamp of frame 0, sub-frame 0 (125 us units)
  std::vector<Fault> faults;

  // Says which field violates what, e.g. "speed_mbps = 100. Violated constraint: one of 12,
  // 480, 5000, 10000, 20000".
  absl::Status Validate() const;
};

// A command the device received on 0x02.
struct ReceivedCommand {
  uint32_t sequence = 0;
  uint32_t command = 0;
  uint32_t max_response_length = 0;
  std::vector<uint32_t> params;
};

// A control request the device received (SETUP packet fields).
struct ReceivedControl {
  uint8_t request_type = 0;
  uint8_t request = 0;
  uint16_t value = 0;
  uint16_t index = 0;
  uint16_t length = 0;
};

struct Counters {
  int urbs_in_flight = 0;    // submitted, not yet reaped (pending + completed)
  int iso_urbs_pending = 0;  // submitted on 0x84, not yet completed
  int64_t urbs_submitted = 0;
  int64_t urbs_discarded = 0;  // completed with -ENOENT by DISCARDURB
  int64_t iso_urbs_completed = 0;
  int64_t iso_bytes = 0;         // packet bytes written into iso URBs
  int64_t subframes_served = 0;  // sub-frames whose data packets all went out
  int64_t commands_received = 0;
  int64_t status_polls = 0;  // 0x16 with kStatusParam
  int configuration = 1;
  int interface1_alt_setting = 0;
  bool claimed[2] = {false, false};  // interfaces 0 and 1
  bool streaming = false;            // 0x2B(1) received, 0x2B(0) not since
  bool unplugged = false;
};

class EmulatedKinect2 {
 public:
  // Validates `options`, adds the device to a new umockdev testbed and attaches the handler.
  // FailedPrecondition outside umockdev's preload library; InvalidArgument for bad options;
  // Internal when umockdev refuses the device.
  static absl::StatusOr<std::unique_ptr<EmulatedKinect2>> Create(Options options);
  ~EmulatedKinect2();
  EmulatedKinect2(const EmulatedKinect2&) = delete;
  EmulatedKinect2& operator=(const EmulatedKinect2&) = delete;

  // Whether this process runs under umockdev's preload library (else nothing is emulated).
  static bool Available();

  std::string DevicePath() const;  // /dev/bus/usb/BBB/DDD
  Counters counters() const;
  std::vector<ReceivedCommand> Commands() const;
  std::vector<ReceivedControl> ControlRequests() const;

  // The device goes away now (see the limits above); idempotent. Beware libusb 1.0.26's
  // libusb_set_interface_alt_setting on a device that libusb's hotplug thread has seen leave:
  // it unlocks a mutex it never locked, and libusb_close then aborts (libusb #1199, fixed in
  // 1.0.27); code under test must not set an alt setting after LIBUSB_ERROR_NO_DEVICE.
  void Unplug();

  class Device;  // the kernel's and the camera's state (emulated_kinect2.cc)

 private:
  explicit EmulatedKinect2(std::unique_ptr<Device> device);
  std::unique_ptr<Device> device_;
};

}  // namespace transient::kinect2::testing

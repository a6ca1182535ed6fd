// A Kinect v2 on libusb-1.0 (Debian 12: 1.0.26): finding it, its start and stop sequences,
// the commands that read its serial, firmware, intrinsics and P0 tables, and the pool of
// isochronous transfers on endpoint 0x84 with the event thread that reaps them
// (../shared/research/libusb.md §1.1, §1.2, §7.5).
//
// Threads: Open, Start and Stop from one thread. The packet sink runs on the event thread, and
// on the caller's thread while Start or Stop reap transfers themselves (a failed Start, the
// commands of Stop): it must never block on the consumer, nor take a lock the caller holds
// around Start or Stop (the source queues with drop-oldest and holds no lock around them).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "kinect2/command.h"
#include "kinect2/stream_parser.h"

namespace transient::kinect2 {

inline constexpr uint16_t kVendorId = 0x045E;
inline constexpr uint16_t kProductIds[] = {0x02D8, 0x02C4};
inline constexpr uint8_t kDepthEndpoint = 0x84;
inline constexpr int kControlInterface = 0, kDepthInterface = 1;

// The udev rule that lets a user open the camera, for messages and docs.
inline constexpr char kUdevRule[] =
    "SUBSYSTEM==\"usb\", ATTR{idVendor}==\"045e\", ATTR{idProduct}==\"02d8\", MODE=\"0666\" "
    "(and 02c4) in /etc/udev/rules.d/90-kinect2.rules";

struct UsbKinect2Options {
  std::string serial;  // empty: the only Kinect v2 attached (an error when there are several)
  absl::Duration command_timeout = absl::Milliseconds(1000);
  absl::Duration ready_timeout = absl::Seconds(5);  // status 0x090000 bit 0 after the mode commands
  int transfers = 16;  // iso transfers in flight
  int packets = 32;    // iso packets per transfer, kIsoPacketBytes each
};

// What the camera told at open.
struct UsbKinect2Info {
  std::string serial;
  std::string firmware;  // "4.0.3912.0"
  uint16_t product_id = 0;
  int bus = 0, address = 0;
  int speed_mbps = 0;  // 5000 for USB 3
  DepthIntrinsics intrinsics;
  std::vector<uint8_t> p0_tables;  // the raw P0 response (kinect2_format.h)
};

// A Kinect v2 as `transient devices` lists it.
struct Kinect2Listing {
  std::string serial;  // empty when the device could not be opened
  uint16_t product_id = 0;
  int bus = 0, address = 0;
  int speed_mbps = 0;
  std::string problem;  // why it cannot be used ("USB 2 port", "permission denied: ..."), or ""
};
// Every Kinect v2 on the machine's USB buses; an empty list when there are none or libusb has
// no access to USB at all.
std::vector<Kinect2Listing> ListKinect2();

class UsbKinect2 {
 public:
  // Finds the camera (by serial when given), checks USB 3 and the depth endpoint's bandwidth,
  // claims interfaces 0 and 1, and reads firmware, serial, depth intrinsics and P0 tables.
  // Errors name the camera and what to do: NotFound (none, or none with that serial: the
  // serials found are listed), PermissionDenied (the udev rule), FailedPrecondition (a USB 2
  // port, too little iso bandwidth, busy: another program has it), Unavailable (unplugged,
  // or a command without answer within command_timeout), DataLoss (a malformed response).
  static absl::StatusOr<std::unique_ptr<UsbKinect2>> Open(const UsbKinect2Options& options);
  ~UsbKinect2();
  UsbKinect2(const UsbKinect2&) = delete;
  UsbKinect2& operator=(const UsbKinect2&) = delete;

  const UsbKinect2Info& info() const { return info_; }

  // Called on the event thread with every packet of every completed transfer, in order.
  using PacketSink = std::function<void(const IsoPacket& packet, absl::Time now)>;
  // The start sequence (mode, wait for status bit 0, init streams, interface 1 alt 1,
  // streaming on), then the transfers and the event thread. FailedPrecondition when started.
  absl::Status Start(PacketSink sink);
  // Cancels the transfers and waits for every callback, then interface 1 alt 0 and the stop
  // commands (skipped when the device is gone). Idempotent.
  absl::Status Stop();

  // The device went away (a transfer or command said so).
  bool lost() const { return lost_.load(); }
  // Streaming, but no transfer is in flight any more: every resubmission failed (usbfs memory,
  // I/O errors) without the device being lost. Nothing more will come until Stop and Start.
  bool stalled() const;
  // Transfers that completed with an error status (not cancelled, not lost) and resubmissions
  // that failed.
  int64_t transfer_errors() const { return transfer_errors_.load(); }

 private:
  struct Impl;
  explicit UsbKinect2(std::unique_ptr<Impl> impl);

  std::unique_ptr<Impl> impl_;
  UsbKinect2Info info_;
  std::atomic<bool> lost_{false};
  std::atomic<int64_t> transfer_errors_{0};
};

}  // namespace transient::kinect2

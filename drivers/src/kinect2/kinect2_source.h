// The Kinect v2 capture source, "usb:kinect2[?serial=...&key=value...]": the camera's raw
// correlation sub-frames over libusb (usb_kinect2.h), one RawFrame per sub-frame 0..8 with its
// own footer timestamp, in the fixed schedule of kinect2_format.h (harmonics 10, 2, 15 of
// 8 MHz, three 120-degree steps, c_0 not measured). The camera's P0 tables are its calibration
// (embedded_calibration), its depth intrinsics the camera model.
//
// The libusb event thread parses the iso packets (stream_parser.h) into sub-frames and complete
// depth frames, and queues those without ever waiting for the consumer: when `queue` frames
// wait, the oldest is dropped and counted. Next unpacks a queued frame's nine sub-images. An
// unplugged camera is Unavailable (the daemon reopens it with backoff).
#pragma once

#include <memory>
#include <span>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/source_registry.h"

namespace transient::kinect2 {

// The URI's keys, for `transient sources`.
std::span<const SourceKey> Kinect2Keys();

// Opens the camera (UsbKinect2::Open's errors), InvalidArgument for a bad key or value.
absl::StatusOr<std::unique_ptr<CaptureSource>> OpenKinect2Source(absl::string_view uri);

}  // namespace transient::kinect2

// The keys of a `v4l2:` URI (v4l2_source.h, docs/v4l2.md): what they mean, their defaults by
// profile, and their parsing and checks.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "transient/drivers/source_registry.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/image.h"
#include "v4l2/frame_unpacker.h"
#include "v4l2/sequence_assembler.h"

namespace transient::v4l2 {

enum class Profile {
  kGeneric,   // the sensor runs the URI's schedule by itself; no control is set
  kMlx7502x,  // the proposed ToF controls, set and read back before every sequence, trigger
};

struct V4l2Options {
  std::string device;  // the video node
  std::string subdev;  // the node with the controls; "" = the video node
  Profile profile = Profile::kGeneric;
  SampleFormat sample;
  ImageGeometry geometry = {640, 480};
  ScheduleOptions schedule;
  bool proxy_given = false;  // proxy_f was in the URI (else mlx7502x: the control's minimum)
  std::vector<int64_t> phases_deg = {0, 90, 180, 270};  // the buckets in the sensor's order
  AssemblerOptions assembly;  // alignment and gap; phases and sizes come from the format
  absl::Duration watchdog = absl::Seconds(1);
  int restarts = 3;  // in a row without a whole sequence
  int buffers = 8;
  int subframes = 1;  // phase images per buffer
  PinholeIntrinsics intrinsics;
  std::vector<std::pair<std::string, std::vector<int64_t>>> passthrough;  // ctrl.*
};

// The keys with their defaults and units, for `transient sources` and the docs.
std::span<const SourceKey> V4l2Keys();

// Parses "v4l2:/dev/videoN?key=value&..." and checks what can be checked without the device.
// InvalidArgument naming the key and value and what is accepted.
absl::StatusOr<V4l2Options> ParseV4l2Uri(absl::string_view uri);

}  // namespace transient::v4l2

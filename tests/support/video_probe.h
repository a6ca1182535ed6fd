// What an MP4 file holds, as ffprobe (Debian's ffmpeg) decodes it: the tests read back the
// videos that `transient view` writes.
#pragma once

#include <string>

#include "absl/status/statusor.h"

namespace transient::testing {

struct VideoInfo {
  int frames = 0;  // decoded video frames
  int width = 0;
  int height = 0;
  std::string codec;  // "h264"
};

// The first video stream of `path`, every frame decoded and counted. NotFound / DataLoss with
// ffprobe's message when it cannot read the file.
absl::StatusOr<VideoInfo> ProbeVideo(const std::string& path);

}  // namespace transient::testing

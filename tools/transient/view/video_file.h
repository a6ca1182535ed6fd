// H.264 MP4 video from RGB figures, encoded by an `ffmpeg` process (Debian's, libx264) that
// reads raw frames on its standard input; written under a temporary name and renamed when
// closed, so a failed run leaves no file. A subprocess rather than OpenCV's videoio: that module
// pulls FFmpeg and GStreamer (~290 shared libraries, 0.2 s) into every process that links it.
#pragma once

#include <sys/types.h>

#include <string>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace transient::tools {

class Mp4Writer {
 public:
  // `path` must end in ".mp4"; `size` must be even in both dimensions (4:2:0 chroma) and the
  // frames per second in (0, 240]. InvalidArgument for these, NotFound/PermissionDenied for a
  // directory that is missing or read-only, Unavailable when ffmpeg cannot be started.
  [[nodiscard]] static absl::StatusOr<Mp4Writer> Open(const std::string& path, double fps,
                                                      cv::Size size);
  Mp4Writer(Mp4Writer&&) noexcept;
  Mp4Writer& operator=(Mp4Writer&&) = delete;
  ~Mp4Writer();  // stops ffmpeg and removes the temporary file unless Close() succeeded

  // Appends one 8-bit RGB frame of the writer's size. Unavailable (with ffmpeg's last words)
  // when the encoder has gone.
  absl::Status Write(const cv::Mat& rgb);
  // Ends the input, waits for ffmpeg to finish the file and renames it into place.
  absl::Status Close();
  int frames() const { return frames_; }

 private:
  Mp4Writer() = default;
  // Waits for ffmpeg to exit; its status, or Unavailable with the end of its log.
  absl::Status Finish();
  std::string LogTail() const;

  std::string path_;
  std::string temporary_path_;
  std::string log_path_;  // ffmpeg's stderr
  cv::Size size_;
  int input_ = -1;  // our end of ffmpeg's standard input (a socket: no SIGPIPE, MSG_NOSIGNAL)
  pid_t encoder_ = -1;
  int frames_ = 0;
  bool armed_ = false;  // the destructor removes the temporary files
};

}  // namespace transient::tools

// H.264 MP4 video from RGB figures through OpenCV's VideoWriter (FFmpeg backend, fourcc avc1),
// written under a temporary name and renamed when closed, so a failed run leaves no file.
#pragma once

#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace cv {
class VideoWriter;
}

namespace transient::tools {

class Mp4Writer {
 public:
  // `path` must end in ".mp4"; `size` must be even in both dimensions (4:2:0 chroma) and the
  // frames per second in (0, 240]. InvalidArgument for these, NotFound/PermissionDenied for a
  // directory that is missing or read-only, Unavailable when OpenCV cannot open an H.264 writer.
  [[nodiscard]] static absl::StatusOr<Mp4Writer> Open(const std::string& path, double fps,
                                                      cv::Size size);
  Mp4Writer(Mp4Writer&&) noexcept;
  Mp4Writer& operator=(Mp4Writer&&) = delete;
  ~Mp4Writer();  // removes the temporary file unless Close() succeeded

  // Appends one 8-bit RGB frame of the writer's size.
  absl::Status Write(const cv::Mat& rgb);
  // Finishes the file and renames it into place.
  absl::Status Close();
  int frames() const { return frames_; }

 private:
  Mp4Writer() = default;

  std::string path_;
  std::string temporary_path_;
  cv::Size size_;
  std::unique_ptr<cv::VideoWriter> writer_;
  int frames_ = 0;
  bool armed_ = false;  // the destructor removes temporary_path_
};

}  // namespace transient::tools

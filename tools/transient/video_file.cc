// OpenCV VideoWriter behind a Status interface; OpenCV's exceptions stop here.
#include "tools/transient/video_file.h"

#include <unistd.h>

#include <filesystem>
#include <system_error>
#include <utility>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace transient::tools {

absl::StatusOr<Mp4Writer> Mp4Writer::Open(const std::string& path, double fps, cv::Size size) {
  if (!absl::EndsWith(path, ".mp4")) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": expected a name ending in .mp4"));
  }
  if (!(fps > 0.0 && fps <= 240.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", fps, " frames per second: expected 0 < fps <= 240"));
  }
  if (size.width <= 0 || size.height <= 0 || size.width % 2 != 0 || size.height % 2 != 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": frames of ", size.width, "x",
                                                   size.height,
                                                   " px: expected even, positive sizes"));
  }
  const std::filesystem::path final_path(path);
  const std::filesystem::path directory =
      final_path.has_parent_path() ? final_path.parent_path() : std::filesystem::path(".");
  std::error_code error;
  if (!std::filesystem::is_directory(directory, error)) {
    return absl::NotFoundError(
        absl::StrCat(path, ": directory ", directory.string(), " does not exist"));
  }
  if (::access(directory.c_str(), W_OK) != 0) {
    return absl::PermissionDeniedError(
        absl::StrCat(path, ": directory ", directory.string(), " is not writable"));
  }
  Mp4Writer writer;
  writer.path_ = path;
  // FFmpeg picks the container from the extension, so the temporary name keeps ".mp4".
  writer.temporary_path_ =
      (directory / absl::StrCat(".", final_path.stem().string(), ".tmp-", ::getpid(), ".mp4"))
          .string();
  writer.size_ = size;
  writer.writer_ = std::make_unique<cv::VideoWriter>();
  writer.armed_ = true;
  try {
    if (!writer.writer_->open(writer.temporary_path_, cv::CAP_FFMPEG,
                              cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps, size, true)) {
      return absl::UnavailableError(
          absl::StrCat(path, ": OpenCV cannot open an H.264 (avc1) MP4 writer"));
    }
  } catch (const cv::Exception& e) {
    return absl::UnavailableError(absl::StrCat(path, ": OpenCV: ", e.what()));
  }
  return writer;
}

Mp4Writer::Mp4Writer(Mp4Writer&& other) noexcept
    : path_(std::move(other.path_)),
      temporary_path_(std::move(other.temporary_path_)),
      size_(other.size_),
      writer_(std::move(other.writer_)),
      frames_(other.frames_),
      armed_(std::exchange(other.armed_, false)) {}

Mp4Writer::~Mp4Writer() {
  if (!armed_) return;
  if (writer_ != nullptr) {
    try {
      writer_->release();
    } catch (const cv::Exception&) {  // nothing to report it to; the run has failed already
    }
  }
  std::error_code ignored;
  std::filesystem::remove(temporary_path_, ignored);
}

absl::Status Mp4Writer::Write(const cv::Mat& rgb) {
  if (rgb.type() != CV_8UC3 || rgb.size() != size_) {
    return absl::InternalError(absl::StrCat(path_, ": frame of ", rgb.cols, "x", rgb.rows,
                                            " px for a video of ", size_.width, "x",
                                            size_.height));
  }
  try {
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    writer_->write(bgr);
  } catch (const cv::Exception& e) {
    return absl::UnavailableError(absl::StrCat(path_, ": writing frame ", frames_, ": ", e.what()));
  }
  ++frames_;
  return absl::OkStatus();
}

absl::Status Mp4Writer::Close() {
  try {
    writer_->release();
  } catch (const cv::Exception& e) {
    return absl::UnavailableError(absl::StrCat(path_, ": finishing the video: ", e.what()));
  }
  std::error_code error;
  if (std::filesystem::file_size(temporary_path_, error) == 0 || error) {
    return absl::UnavailableError(absl::StrCat(path_, ": OpenCV wrote no video"));
  }
  std::filesystem::rename(temporary_path_, path_, error);
  if (error) {
    return absl::PermissionDeniedError(absl::StrCat(
        path_, ": cannot rename ", temporary_path_, " into place (", error.message(), ")"));
  }
  armed_ = false;
  return absl::OkStatus();
}

}  // namespace transient::tools

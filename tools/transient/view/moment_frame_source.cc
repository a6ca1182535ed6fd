// Moment frames reconstructed on demand.
#include "tools/transient/view/moment_frame_source.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "transient/reconstruct/status_context.h"

namespace transient::tools {

std::unique_ptr<MomentFrameSource> MomentFrameSource::FromFrames(std::string name,
                                                                 std::vector<MomentImage> frames,
                                                                 ReconstructionSettings settings) {
  std::unique_ptr<MomentFrameSource> source(
      new MomentFrameSource(std::move(name), std::move(settings)));
  if (!frames.empty()) source->geometry_ = frames.front().geometry;
  source->frames_ = static_cast<int64_t>(frames.size());
  source->held_ = std::move(frames);
  return source;
}

std::unique_ptr<MomentFrameSource> MomentFrameSource::FromFile(std::string name, MomentFile file,
                                                               FrameRange range,
                                                               ReconstructionSettings settings) {
  std::unique_ptr<MomentFrameSource> source(
      new MomentFrameSource(std::move(name), std::move(settings)));
  source->geometry_ = file.geometry();
  source->frames_ = range.count;
  source->first_ = range.first;
  source->file_.emplace(std::move(file));
  return source;
}

absl::Status MomentFrameSource::ReadFrame(int64_t frame, ProductSet wanted,
                                          TransientFrame* out) const {
  if (frame < 0 || frame >= frames_) {
    return absl::OutOfRangeError(
        absl::StrCat(name_, ": frame ", frame, " is outside 0..", frames_ - 1));
  }
  const MomentImage* moments = nullptr;
  if (file_.has_value()) {
    if (absl::Status status = file_->ReadFrame(first_ + frame, &buffer_); !status.ok()) {
      return status;
    }
    if (absl::Status status = buffer_.Validate(); !status.ok()) {
      return absl::InternalError(
          absl::StrCat(name_, ": frame ", first_ + frame, ": ", status.message()));
    }
    moments = &buffer_;
  } else {
    moments = &held_[frame];
  }
  out->index = frame;
  if (absl::Status status = ReconstructFrame(*moments, settings_, wanted, out); !status.ok()) {
    return WithContext(name_, status);
  }
  return absl::OkStatus();
}

}  // namespace transient::tools

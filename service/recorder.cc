// The daemon's recordings: requests from the RPC threads, files on the source thread.
#include "recorder.h"

#include <filesystem>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"

namespace transient::service {

absl::StatusOr<RecordingStatus> Recorder::Start(
    const std::string& path, uint64_t max_frames, int deflate_level, bool accepting,
    const std::function<std::string()>& describe_source, absl::Duration timeout) {
  if (path.empty()) return absl::InvalidArgumentError("path: expected a file name");
  if (deflate_level < 0 || deflate_level > 9) {
    return absl::InvalidArgumentError(
        absl::StrCat("deflate_level = ", deflate_level, ": expected 0..9"));
  }
  if (max_frames > kMaxRecordingFrames) {
    return absl::InvalidArgumentError(absl::StrCat("max_frames = ", max_frames, ": expected 0..",
                                                   kMaxRecordingFrames, " (0 = until stopped)"));
  }
  if (std::filesystem::exists(path)) {
    return absl::AlreadyExistsError(
        absl::StrCat("path: ", path, " exists; a recording never replaces a file"));
  }
  auto pending = std::make_shared<PendingStart>();
  pending->path = path;
  pending->max_frames = max_frames;
  pending->deflate_level = deflate_level;
  absl::MutexLock lock(&mu_);
  if (status_.active) {
    return absl::FailedPreconditionError(
        absl::StrCat("a recording to ", status_.path, " is in progress"));
  }
  if (pending_ != nullptr) {
    return absl::FailedPreconditionError("another StartRecording is being served");
  }
  if (!accepting || shut_down_) {
    return absl::FailedPreconditionError("the pipeline is not running");
  }
  pending_ = pending;
  auto done = [&pending]() -> bool { return pending->done; };
  if (!mu_.AwaitWithTimeout(absl::Condition(&done), timeout)) {
    if (pending_ == pending) pending_ = nullptr;
    return absl::UnavailableError(absl::StrCat("no frame from ", describe_source(), " within ",
                                               absl::FormatDuration(timeout),
                                               " to begin the recording"));
  }
  if (!pending->result.ok()) return pending->result;
  return status_;
}

absl::StatusOr<RecordingStatus> Recorder::Stop(absl::Duration timeout) {
  absl::MutexLock lock(&mu_);
  if (!status_.active) {
    return absl::FailedPreconditionError(
        status_.path.empty()
            ? std::string("no recording in progress")
            : absl::StrCat("no recording in progress; the last was ", status_.path,
                           status_.error.empty() ? "" : " (", status_.error,
                           status_.error.empty() ? "" : ")"));
  }
  stop_requested_ = true;
  auto stopped = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    return !status_.active || shut_down_;
  };
  if (!mu_.AwaitWithTimeout(absl::Condition(&stopped), timeout)) {
    return absl::UnavailableError(
        absl::StrCat("the recording did not close within ", absl::FormatDuration(timeout)));
  }
  return status_;
}

RecordingStatus Recorder::status() const {
  absl::MutexLock lock(&mu_);
  return status_;
}

void Recorder::Shutdown() {
  absl::MutexLock lock(&mu_);
  shut_down_ = true;
}

std::shared_ptr<Recorder::PendingStart> Recorder::TakeRequests(bool with_start, bool* stop) {
  absl::MutexLock lock(&mu_);
  *stop = stop_requested_;
  stop_requested_ = false;
  // A start stays pending until served, so that its own timeout can withdraw it.
  if (!with_start) return nullptr;
  return std::exchange(pending_, nullptr);
}

void Recorder::ServeStart(PendingStart& start, const RawFrame* frame, const CaptureSource* source,
                          std::shared_ptr<const CalibrationTable> calibration,
                          const std::string& why) {
  absl::Status result;
  if (writer_.has_value()) {
    result = absl::FailedPreconditionError(
        absl::StrCat("a recording to ", writer_->path(), " is in progress"));
  } else if (frame == nullptr || source == nullptr) {
    result = absl::FailedPreconditionError(why);
  } else {
    // Created with the first frame's saturation level, as `transient record` does.
    const CaptureWriterOptions options{.pixel_type = CapturePixelType::kFloat32,
                                       .deflate_level = start.deflate_level,
                                       .source_uri = source->uri(),
                                       .saturation_level = frame->saturation_level};
    absl::StatusOr<CaptureWriter> created =
        CaptureWriter::Create(start.path, source->camera(), source->schedule(), options);
    if (created.ok()) {
      absl::StatusOr<GroundTruth> truth = source->GroundTruthAt(frame->config.timestamp_s);
      if (truth.ok()) result = created->SetGroundTruth(*truth);
      if (result.ok() && calibration != nullptr) result = created->EmbedCalibration(*calibration);
      if (result.ok()) {
        writer_.emplace(*std::move(created));
        schedule_ = std::make_shared<const AcquisitionSchedule>(source->schedule());
        limit_raw_frames_ = start.max_frames *  // max_frames <= kMaxRecordingFrames
                            static_cast<uint64_t>(schedule_->raw_frames_per_frame());
        waiting_for_cycle_start_ = true;
      } else {
        (void)created->Close();
        std::error_code ignored;
        std::filesystem::remove(start.path, ignored);
      }
    } else {
      result = created.status();
    }
  }
  if (result.ok()) log_(absl::StrCat("recording: started ", start.path));
  absl::MutexLock lock(&mu_);
  if (result.ok()) status_ = RecordingStatus{.path = start.path, .active = true, .error = {}};
  start.result = result;
  start.done = true;
}

void Recorder::OnFrame(const RawFrame& frame, const CaptureSource& source,
                       std::shared_ptr<const CalibrationTable> calibration) {
  bool stop = false;
  std::shared_ptr<PendingStart> start = TakeRequests(/*with_start=*/true, &stop);
  if (stop) Finish("");
  if (start != nullptr) ServeStart(*start, &frame, &source, std::move(calibration), "");
  if (!writer_.has_value()) return;
  if (waiting_for_cycle_start_) {
    // The file begins with a whole capture cycle: take 0, first exposure.
    absl::StatusOr<int> index = schedule_->IndexOf(frame.config);
    if (!index.ok() || *index != 0) return;
    waiting_for_cycle_start_ = false;
  }
  if (absl::Status status = writer_->Append(frame); !status.ok()) {
    Finish(absl::StrCat("stopped: ", status.message()));
    return;
  }
  {
    absl::MutexLock lock(&mu_);
    status_.raw_frames = static_cast<uint64_t>(writer_->frames());
    status_.flushed_frames = static_cast<uint64_t>(writer_->flushed_frames());
  }
  if (limit_raw_frames_ > 0 && static_cast<uint64_t>(writer_->frames()) >= limit_raw_frames_) {
    Finish("");
  }
}

void Recorder::OnNoFrame(bool final, const std::string& why) {
  bool stop = false;
  std::shared_ptr<PendingStart> start = TakeRequests(/*with_start=*/final, &stop);
  if (stop) Finish("");
  if (start != nullptr) ServeStart(*start, nullptr, nullptr, nullptr, why);
}

void Recorder::Finish(const std::string& error) {
  if (!writer_.has_value()) return;
  std::string message = error;
  if (absl::Status status = writer_->Close(); !status.ok() && message.empty()) {
    message = absl::StrCat("closing failed: ", status.message());
  }
  const uint64_t frames = static_cast<uint64_t>(writer_->frames());
  const std::string path = writer_->path();
  writer_.reset();
  schedule_.reset();
  {
    absl::MutexLock lock(&mu_);
    status_.active = false;
    status_.raw_frames = frames;
    status_.flushed_frames = frames;
    status_.error = message;
  }
  log_(absl::StrCat("recording: ", path, " closed with ", frames, " raw frames",
                    message.empty() ? "" : "; ", message));
}

}  // namespace transient::service

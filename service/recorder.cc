// The daemon's recordings: requests from the RPC threads, files on the source thread.
#include "recorder.h"

#include <sys/resource.h>
#include <sys/statvfs.h>

#include <filesystem>
#include <limits>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"

namespace transient::service {

absl::StatusOr<RecordingStatus> Recorder::Start(
    const RecordingTarget& target, uint64_t max_frames, int deflate_level, bool accepting,
    const std::function<std::string()>& describe_source, absl::Duration timeout) {
  const std::string& path = target.path;
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
        absl::StrCat("path: ", target.name, " exists; a recording never replaces a file"));
  }
  auto pending = std::make_shared<PendingStart>();
  pending->target = target;
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
        absl::StrCat("a recording to ", name_, " is in progress"));
  } else if (frame == nullptr || source == nullptr) {
    result = absl::FailedPreconditionError(why);
  } else {
    // Created with the first frame's saturation level, as `transient record` does.
    const CaptureWriterOptions options{.pixel_type = CapturePixelType::kFloat32,
                                       .deflate_level = start.deflate_level,
                                       .source_uri = source->uri(),
                                       .saturation_level = frame->saturation_level};
    absl::StatusOr<CaptureWriter> created =
        CaptureWriter::Create(start.target.path, source->camera(), source->schedule(), options);
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
        name_ = start.target.name;
        byte_budget_ = start.target.byte_budget;
      } else {
        (void)created->Close();
        std::error_code ignored;
        std::filesystem::remove(start.target.path, ignored);
      }
    } else {
      result = created.status();
    }
  }
  if (result.ok()) log_(absl::StrCat("recording: started ", start.target.path));
  absl::MutexLock lock(&mu_);
  if (result.ok()) {
    status_ = RecordingStatus{.path = start.target.name, .active = true, .error = {}};
  }
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
  if (absl::Status room = CheckRoom(frame); !room.ok()) {
    Finish(absl::StrCat("stopped: ", room.message()));
    return;
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

absl::Status Recorder::CheckRoom(const RawFrame& frame) {
  // The file's size on disk, and for each frame not yet flushed (and this one) its
  // uncompressed size, plus kRecordingOverheadBytes: an upper bound of what the file holds after
  // this append and its close. Near a limit the frames held in memory are flushed, so that the
  // bound is the file's size.
  const uint64_t frame_bytes = frame.pixels.size() * sizeof(float);
  for (bool flushed = false;; flushed = true) {
    std::error_code error;
    const uint64_t on_disk = std::filesystem::file_size(writer_->path(), error);
    if (error) return absl::ErrnoToStatus(error.value(), "the file's size cannot be read");
    const uint64_t unflushed =
        static_cast<uint64_t>(writer_->frames() - writer_->flushed_frames()) + 1;
    const uint64_t growth = unflushed * frame_bytes + kRecordingOverheadBytes;
    absl::Status room;
    if (byte_budget_ != std::numeric_limits<uint64_t>::max() &&
        on_disk + growth > byte_budget_) {
      room = absl::ResourceExhaustedError(
          absl::StrCat("the data directory's quota (", byte_budget_,
                       " bytes for this recording) would be passed by the next frame"));
    }
    struct statvfs file_system;
    if (room.ok() && ::statvfs(writer_->path().c_str(), &file_system) == 0 &&
        static_cast<uint64_t>(file_system.f_bavail) * file_system.f_frsize < growth) {
      room = absl::ResourceExhaustedError(absl::StrCat(
          "the disk is full: ",
          static_cast<uint64_t>(file_system.f_bavail) * file_system.f_frsize,
          " bytes free, the next frame may need ", growth));
    }
    struct rlimit limit;
    if (room.ok() && ::getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY &&
        on_disk + growth > limit.rlim_cur) {
      room = absl::ResourceExhaustedError(absl::StrCat(
          "the next frame may take the file past the process's file size limit (RLIMIT_FSIZE = ",
          limit.rlim_cur, " bytes)"));
    }
    if (room.ok() || flushed || unflushed == 1 || !writer_->Flush().ok()) return room;
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
  if (absl::Status status = writer_->Close(); !status.ok()) {
    absl::StrAppend(&message, message.empty() ? "" : "; ", "closing failed: ", status.message());
  }
  const uint64_t frames = static_cast<uint64_t>(writer_->frames());
  // A file whose writes failed keeps what was flushed before (Close flushes the rest).
  const uint64_t flushed = static_cast<uint64_t>(writer_->flushed_frames());
  const std::string path = writer_->path();
  writer_.reset();
  schedule_.reset();
  {
    absl::MutexLock lock(&mu_);
    status_.active = false;
    status_.raw_frames = frames;
    status_.flushed_frames = flushed;
    status_.error = message;
  }
  log_(absl::StrCat("recording: ", path, " closed with ", frames, " raw frames",
                    message.empty() ? "" : "; ", message));
}

}  // namespace transient::service

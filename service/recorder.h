// Recording a source's raw frames into a capture file while the daemon streams (StartRecording,
// StopRecording; DESIGN.md, "The data path", step 5). The RPC threads ask; the source thread
// serves a start with the frame that begins the file, appends every frame from the next cycle
// boundary on, and closes the file when asked, at max_frames, or when its source ends, so that a
// recording holds one source's frames under one schedule. Every file operation happens on the
// source thread, under the HDF5 lock.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "transient/formats/hdf5_lock.h"
#include "transient/drivers/capture_source.h"
#include "transient/formats/capture_file.h"
#include "transient/reconstruct/calibration.h"
#include "transient/service/pipeline.h"

namespace transient::service {

inline constexpr uint64_t kMaxRecordingFrames = uint64_t{1} << 32;

// What HDF5 adds to a capture file beyond its frames' data (the header, the camera and schedule
// records, chunk indexes, the calibration): the margin the quota keeps free for them.
inline constexpr uint64_t kRecordingOverheadBytes = uint64_t{1} << 20;

// Where a recording goes: `name` as the client gave it (reported in RecordingStatus::path),
// `path` the file it names (DataDir::NewFilePath), and the bytes the file may grow to before
// the data directory's quota is reached (UINT64_MAX: no quota).
struct RecordingTarget {
  std::string name;
  std::string path;
  uint64_t byte_budget = std::numeric_limits<uint64_t>::max();
};

class Recorder {
 public:
  using Log = std::function<void(const std::string&)>;
  explicit Recorder(Log log) : log_(std::move(log)) {}

  // ---- RPC threads ----

  // Asks the source thread to begin `target.path` (a new file: never replaces one) with its
  // next frame and waits up to `timeout` for it. InvalidArgument naming the field for an empty
  // path, a deflate level outside 0..9 or max_frames above kMaxRecordingFrames; AlreadyExists;
  // FailedPrecondition during a recording, while another start is served, or when not
  // `accepting` (the pipeline is not running); Unavailable "no frame from <source> within ..."
  // naming `describe_source()` on timeout; the writer's errors.
  // The recording stops by itself (RecordingStatus::error says why) before a frame could take
  // the file past `target.byte_budget`, the free space of its file system or the process's
  // RLIMIT_FSIZE: the frame is counted at its uncompressed size, as is each frame written since
  // the last flush (HDF5 may hold those in memory), plus kRecordingOverheadBytes. A write that
  // fails all the same (the disk filled by another process) stops it too; the frames flushed
  // before stay readable (CaptureWriter::Close).
  absl::StatusOr<RecordingStatus> Start(const RecordingTarget& target, uint64_t max_frames,
                                        int deflate_level, bool accepting,
                                        const std::function<std::string()>& describe_source,
                                        absl::Duration timeout = absl::Seconds(10))
      ABSL_LOCKS_EXCLUDED(mu_);
  // Asks the source thread to close the file and waits up to `timeout`. FailedPrecondition
  // without a recording (naming the last one and why it stopped).
  absl::StatusOr<RecordingStatus> Stop(absl::Duration timeout = absl::Seconds(10))
      ABSL_LOCKS_EXCLUDED(mu_);
  RecordingStatus status() const ABSL_LOCKS_EXCLUDED(mu_);
  // The pipeline stops: waiting calls return.
  void Shutdown() ABSL_LOCKS_EXCLUDED(mu_);

  // ---- the source thread ----

  // Serves a pending start (creating the file with the camera, schedule, ground truth and
  // `calibration` of `source`) and a pending stop, then appends `frame` if a recording has
  // reached a cycle boundary.
  void OnFrame(const RawFrame& frame, const CaptureSource& source,
               std::shared_ptr<const CalibrationTable> calibration)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex()) ABSL_LOCKS_EXCLUDED(mu_);
  // Serves a pending stop. A pending start waits for a frame, unless `final` (no frame will
  // come): then it fails with FailedPrecondition `why`.
  void OnNoFrame(bool final, const std::string& why) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex())
      ABSL_LOCKS_EXCLUDED(mu_);
  // Closes the recording in progress, if any; `error` (e.g. "stopped: the source failed")
  // becomes RecordingStatus::error, "" for a normal end.
  void Finish(const std::string& error) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex())
      ABSL_LOCKS_EXCLUDED(mu_);

 private:
  struct PendingStart {
    RecordingTarget target;
    uint64_t max_frames = 0;
    int deflate_level = 1;
    bool done = false;
    absl::Status result;
  };

  // A pending start served with `frame` (nullptr: failed with `why`).
  void ServeStart(PendingStart& start, const RawFrame* frame, const CaptureSource* source,
                  std::shared_ptr<const CalibrationTable> calibration, const std::string& why)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex()) ABSL_LOCKS_EXCLUDED(mu_);
  // OK when appending `frame` keeps the file within byte_budget_, the free space of its file
  // system and RLIMIT_FSIZE (flushing when that decides); ResourceExhausted saying which limit
  // it would pass otherwise.
  absl::Status CheckRoom(const RawFrame& frame) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  // Takes the pending requests: the start only when `with_start`.
  std::shared_ptr<PendingStart> TakeRequests(bool with_start, bool* stop) ABSL_LOCKS_EXCLUDED(mu_);

  const Log log_;
  mutable absl::Mutex mu_;
  RecordingStatus status_ ABSL_GUARDED_BY(mu_);
  std::shared_ptr<PendingStart> pending_ ABSL_GUARDED_BY(mu_);
  bool stop_requested_ ABSL_GUARDED_BY(mu_) = false;
  bool shut_down_ ABSL_GUARDED_BY(mu_) = false;

  // The source thread's own.
  std::optional<CaptureWriter> writer_;
  std::shared_ptr<const AcquisitionSchedule> schedule_;
  uint64_t limit_raw_frames_ = 0;  // 0 = until stopped
  std::string name_;  // as the client gave it
  uint64_t byte_budget_ = std::numeric_limits<uint64_t>::max();
  bool waiting_for_cycle_start_ = false;
};

}  // namespace transient::service

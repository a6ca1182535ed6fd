// The daemon's pipeline (DESIGN.md, "The data path" and "Threads"): a source thread reads raw
// frames, records them when asked and assembles capture cycles; a reconstruction thread
// demodulates, calibrates, smooths, solves each pixel once per frame and computes the products
// that any subscriber asked for, once, into an immutable frame shared by all of them. Every
// subscriber has its own bounded queue: a slow one loses its oldest frames and is told how
// many; it never stalls the pipeline or the others.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "transient/formats/capture_file.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/calibration.h"
#include "transient/reconstruct/reconstructor.h"
#include "transient/service/data_dir.h"
#include "transient/service/pipeline_stats.h"
#include "transient/service/products.h"
#include "transient/service/reconstruction_config.h"
#include "transient/service/subscription.h"

namespace transient::service {

inline constexpr int kMaxSubscribers = 64;
inline constexpr int64_t kMaxSliceBytesAllStreams = int64_t{256} << 20;

// Opens a source by URI; tests substitute one that fails on purpose.
using SourceOpener =
    std::function<absl::StatusOr<std::unique_ptr<CaptureSource>>(const std::string& uri)>;

struct PipelineOptions {
  std::string source_uri = "sim:mirrors";
  // Calibration: a table (from --calibration or measured at start), or none.
  std::optional<CalibrationTable> calibration = std::nullopt;
  std::string calibration_origin = "none";  // for GetInfo: a path, "measured at start", "none"
  ReconstructionConfig config = {};
  SourceOpener open_source = nullptr;  // nullptr = transient::OpenSource
  int cycle_queue_frames = 2;          // complete cycles waiting for reconstruction
  absl::Duration reopen_backoff_min = absl::Milliseconds(50);
  absl::Duration reopen_backoff_max = absl::Seconds(2);
  // Log lines (stats every few seconds, state changes, errors); nullptr = none.
  std::function<void(const std::string&)> log = nullptr;
  absl::Duration stats_log_interval = absl::Seconds(10);
  // Where recordings and calibration files go (clients name files relative to it), with its
  // quota; nullptr = nowhere: StartRecording and a Calibrate with an output_path are
  // FailedPrecondition.
  std::shared_ptr<const DataDir> data_dir = nullptr;
};

struct CalibrationOutcome {
  CalibrationTable table;
  int frames_rejected = 0;
  int64_t usable_pixels = 0;
};

class Pipeline {
 public:
  // Opens the source (its errors are returned: a bad URI is refused at start) and checks the
  // calibration against it. Threads start with Start().
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<Pipeline>> Create(PipelineOptions options);
  ~Pipeline();  // Stop()

  void Start();
  // Ends the threads, closes every subscription and the recording (its file stays readable).
  // Idempotent.
  void Stop();

  // Source description, fixed at Create (a reopened source must keep its geometry).
  const CameraInfo& camera() const;
  std::string source_uri() const;  // changes when SetConfig changes a simulator's takes
  AcquisitionSchedule schedule() const;
  std::string calibration_origin() const;
  SourceState state() const;

  // Registers a subscriber; it receives every frame published from now on. ResourceExhausted
  // beyond kMaxSubscribers streams, or when the slices of all streams together would exceed
  // kMaxSliceBytesAllStreams per frame.
  absl::StatusOr<std::shared_ptr<Subscription>> Subscribe(std::string peer,
                                                          ProductRequest request,
                                                          int queue_frames);
  void Unsubscribe(const std::shared_ptr<Subscription>& subscription);

  // The latest reconstructed frame (with its solved state), or nullptr before the first.
  std::shared_ptr<const FrameProducts> Latest() const;

  ReconstructionConfig config() const;
  // Validates and applies every field at once, or nothing (InvalidArgument / FailedPrecondition
  // naming the field).
  absl::Status SetConfig(const ReconstructionConfig& config);

  // Measures a calibration from `source_uri` ("" = the calibration scene of a simulated
  // camera), reporting progress; applies it unless keep_current. Runs on the caller's thread;
  // Cancelled once `cancelled` returns true or the pipeline stops. FailedPrecondition for a
  // depth camera (SamplingScheme::kDepth), which has no moments to calibrate.
  // `output_name`: also write a calibration file of that name in the data directory ("" =
  // none); refused as DataDir::NewFilePath and DataDir::CheckRoom say. `source_uri` may name
  // the stream's source, a simulator, or `replay:NAME` of a recording in the data directory;
  // anything else is InvalidArgument (a client must not make the daemon read other files).
  absl::StatusOr<CalibrationOutcome> Calibrate(const std::string& source_uri, int takes,
                                               const std::string& output_name, bool keep_current,
                                               const std::function<void(int, int)>& on_take,
                                               const std::function<bool()>& cancelled);

  // Records the source's raw frames into a capture file (recorder.h) of the name `name` in the
  // data directory (DataDir::NewFilePath). FailedPrecondition for a depth camera
  // (SamplingScheme::kDepth): the capture format holds modulated captures; FailedPrecondition
  // without a data directory; ResourceExhausted when its quota leaves no room for the file's
  // records and one uncompressed frame (DataDir::CheckRoom); the recording stops by itself
  // before its file passes the quota.
  absl::StatusOr<RecordingStatus> StartRecording(const std::string& name, uint64_t max_frames,
                                                 int deflate_level);
  absl::StatusOr<RecordingStatus> StopRecording();

  PipelineStats Stats() const;

 private:
  explicit Pipeline(PipelineOptions options);
  // The path of a new file `name` of the data directory (DataDir::NewFilePath), or
  // FailedPrecondition naming `field` without one.
  absl::StatusOr<std::string> NewDataFile(absl::string_view field, absl::string_view name) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace transient::service

// Replay of a recorded capture file (capture_file.h) as a CaptureSource: the recorded raw frames
// with their exposure metadata, paced like the recording or as fast as the consumer takes them.
//
// URI: "replay:<path>?loop=0|1&pace=realtime|fast&start=<cycle>", every key optional:
//   loop   0 (default): OutOfRange after the last frame; 1: start over, with cycle, sequence and
//          timestamp continuing to increase so that downstream sees new capture cycles.
//   pace   realtime (default): a frame is due when as much time has passed since Start as
//          separates its recorded timestamp from the first delivered frame's; fast: no waiting,
//          every frame delivered (nothing is ever dropped by a replay).
//   start  the recorded cycle to begin with (default: the first frame).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "transient/formats/capture_file.h"
#include "transient/drivers/capture_source.h"

namespace transient {

enum class ReplayPace { kRealtime, kFast };

struct ReplayOptions {
  bool loop = false;
  ReplayPace pace = ReplayPace::kRealtime;
  int64_t start_cycle = -1;  // -1: the first recorded frame
};

// Splits a replay URI into the file path and the options. InvalidArgument naming the key or value
// that is wrong ("replay:x.h5?speed=2: unknown key 'speed'; expected loop, pace, start").
absl::StatusOr<ReplayOptions> ParseReplayUri(absl::string_view uri, std::string* path);

class ReplaySource : public CaptureSource {
 public:
  // Opens the URI's file (CaptureReader::Open's codes) and positions it at `start`
  // (InvalidArgument when no recorded frame has that cycle).
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<ReplaySource>> Open(absl::string_view uri);

  const std::string& uri() const override { return uri_; }
  const CameraInfo& camera() const override { return reader_.camera(); }
  const AcquisitionSchedule& schedule() const override { return reader_.schedule(); }
  SourceCapabilities capabilities() const override;

  absl::Status Start() override;
  // Codes as CaptureSource::Next; DataLoss for a frame whose pixels cannot be read (the next
  // call delivers the frame after it); DeadlineExceeded when pace=realtime and the next frame is
  // not due within `timeout`.
  absl::Status Next(absl::Duration timeout, RawFrame* frame) override;
  absl::Status Stop() override;
  // The recorded ground truth (the scene is static over a recording); Unimplemented without.
  absl::StatusOr<GroundTruth> GroundTruthAt(double timestamp_s) const override;
  // The calibration embedded in the recording, if any ("<path>: /calibration").
  const CalibrationTable* embedded_calibration(std::string* origin) const override;

  // Positions the replay at the first recorded frame of capture cycle `cycle` (as recorded, before
  // any loop offset). InvalidArgument when no frame has that cycle. Pacing restarts from there.
  absl::Status Seek(int64_t cycle);

  const CaptureReader& reader() const { return reader_; }
  // Frames delivered or skipped as unreadable since Open.
  int64_t position() const { return position_; }

 private:
  ReplaySource(std::string uri, CaptureReader reader, ReplayOptions options)
      : uri_(std::move(uri)), reader_(std::move(reader)), options_(options) {}

  std::string uri_;
  CaptureReader reader_;
  ReplayOptions options_;
  bool started_ = false;
  int64_t position_ = 0;  // index of the next frame in the file
  // Added to every delivered frame from the second pass on (loop=1).
  int64_t cycle_offset_ = 0;
  uint64_t sequence_offset_ = 0;
  double timestamp_offset_ = 0.0;
  // Realtime pacing: when the frame with (offset) timestamp `anchor_timestamp_s_` was due.
  bool anchored_ = false;
  absl::Time anchor_time_;
  double anchor_timestamp_s_ = 0.0;
};

}  // namespace transient

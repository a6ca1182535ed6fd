// The interface every camera driver implements (DESIGN.md, "The data path"): a source of raw
// AMCW frames with their exposure metadata. The simulator and the replay of recorded files
// are sources like any other, so everything downstream runs without hardware.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/calibration.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/ground_truth.h"
#include "transient/reconstruct/image.h"

namespace transient {

// What the source can be asked to produce.
struct SourceCapabilities {
  double min_frequency_hz = 0.0;  // 0 when unmodulated exposures are possible
  double max_frequency_hz = 0.0;
  bool arbitrary_phase_shift = false;  // sub-exposures at any phase (arccos, harmonic cancellation)
  bool unmodulated_exposures = false;  // the zeroth-moment pair
  double min_exposure_s = 0.0, max_exposure_s = 0.0;
  bool replay = false;  // a recording: finite, ends with OutOfRange
  // Frames come as fast as they are taken and none may be lost (a replay at pace=fast): a
  // consumer that falls behind waits for room instead of dropping frames.
  bool waits_for_consumer = false;
};

// A count a source keeps of what happened below the frames it delivers (a camera's buffers,
// the sequences it dropped and why, stream restarts), for GetStats and the daemon's log.
struct SourceCounter {
  std::string name;  // snake_case, e.g. "sequences_dropped_error_flag"
  int64_t value = 0;
  std::string description;  // one line: what is counted
};

// A source of raw frames. Use from one thread: Open, Start, Next... , Stop. Sources run the
// acquisition schedule they were opened with, cycle after cycle, and stamp every frame with its
// cycle, take, sequence and timestamp.
class CaptureSource {
 public:
  virtual ~CaptureSource() = default;

  // The URI the source was opened from, e.g. "sim:mirrors?m=3".
  virtual const std::string& uri() const = 0;
  virtual const CameraInfo& camera() const = 0;
  virtual const AcquisitionSchedule& schedule() const = 0;
  virtual SourceCapabilities capabilities() const = 0;

  // Begins acquisition. FailedPrecondition when already started.
  virtual absl::Status Start() = 0;
  // The next raw frame, into `frame` (buffers reused). Codes: DeadlineExceeded when no frame
  // came within `timeout` (the source stays usable); OutOfRange at the end of a recording;
  // Unavailable when the device was lost; FailedPrecondition when not started; DataLoss for a
  // frame a recording cannot deliver (the source moves on to the next one).
  virtual absl::Status Next(absl::Duration timeout, RawFrame* frame) = 0;
  // Ends acquisition; Start may be called again and continues where it stopped.
  virtual absl::Status Stop() = 0;

  // The source's counters since it was opened, in a fixed order; none for most sources. Called
  // from the thread that calls Next.
  virtual std::vector<SourceCounter> Counters() const { return {}; }

  // The ground truth of the scene at `timestamp_s`, when the source knows it (the simulator,
  // the replay of a simulated capture); Unimplemented otherwise.
  virtual absl::StatusOr<GroundTruth> GroundTruthAt(double timestamp_s) const {
    (void)timestamp_s;
    return absl::UnimplementedError(uri() + " has no ground truth");
  }

  // The calibration the source carries (a recording embeds the one it was made with), valid
  // while the source lives, or nullptr. `origin`, when given, receives where it came from for
  // messages ("capture.h5: /calibration").
  virtual const CalibrationTable* embedded_calibration(std::string* origin) const {
    (void)origin;
    return nullptr;
  }
};

// Opens a source by URI through the registry of schemes (source_registry.h): for example
// "sim:<scene>?key=value&..." (simulator.h) or
// "replay:<path>?loop=0|1&pace=realtime|fast&start=<cycle>" (replay_source.h). InvalidArgument
// for an unknown scheme, scene or key, or an impossible schedule; NotFound / InvalidArgument /
// DataLoss for a replay file that cannot be used. The message names what was wrong.
[[nodiscard]] absl::StatusOr<std::unique_ptr<CaptureSource>> OpenSource(absl::string_view uri);

}  // namespace transient

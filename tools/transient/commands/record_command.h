// `transient record` and `transient sim`: raw frames of any source into a capture file that
// survives a crash; `transient record --nats`: a camera's published moment state into a moment
// file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"
#include "transient/wire/nats.h"

namespace transient::tools {

// `transient record --source URI --out FILE (--frames N | --seconds S)` and, through
// SimulatorUri() (simulator.h), `transient sim SCENE --out FILE ...`.
struct RecordArgs {
  std::string source_uri = {};
  std::string output_path = {};
  int64_t frames = 0;     // transient frames (capture cycles) to record; 0 = --seconds decides
  double seconds = 0.0;   // wall-clock seconds to record; 0 = --frames decides
  int deflate_level = 1;  // 0..9
  bool ground_truth = true;  // store the source's ground truth when it has one

  // --nats instead of --source: a camera's MOMENT_STATE frames from NATS JetStream (what
  // transientd --publish put there) into a moment file (transient-moments 1) that `transient
  // reconstruct` reads. nats_start as `transient client --nats-start`; default all: every
  // frame the stream keeps, then live.
  wire::NatsConnectOptions nats = {};
  std::string nats_camera = "camera";
  std::string nats_start = "all";

  // Exactly one of frames > 0 and seconds > 0; deflate 0..9; a source or NATS servers, and an
  // output path.
  absl::Status Validate() const;
};

struct RecordSummary {
  std::string output_path = {};
  std::string source_uri = {};
  int64_t raw_frames = 0;
  int64_t cycles = 0;  // complete capture cycles recorded
  double seconds = 0.0;
  bool interrupted = false;
  bool ground_truth = false;
  bool embedded_calibration = false;  // the source's own calibration went into the file
  std::string schedule = {};  // AcquisitionSchedule::Describe()
  bool moments = false;       // a moment file from NATS: `cycles` frames of moments
};

// Records raw frames from the source into a new capture file (`transient-capture 1`). The file
// is written in place (never to a temporary name): it is readable up to its last flush even if
// the process is killed. It refuses to overwrite an existing file (AlreadyExists). A source
// that ends (OutOfRange, the end of a replay) ends the recording early without an error.
[[nodiscard]] absl::StatusOr<RecordSummary> RunRecord(const RecordArgs& args,
                                                      const CommandHooks& hooks = {});
std::string FormatRecordSummary(const RecordSummary& summary);

// The --nats side of RunRecord: MOMENT_STATE frames into a moment file whose moments are the
// published state's c_0..c_m (already calibrated and biased by the daemon) and whose valid
// pixels are those with a state. Refuses an existing file (AlreadyExists); NotFound when the
// camera has no stream.
[[nodiscard]] absl::StatusOr<RecordSummary> RunRecordNats(const RecordArgs& args,
                                                          const CommandHooks& hooks = {});

}  // namespace transient::tools

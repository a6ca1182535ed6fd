// Measuring a calibration while the daemon streams (the Calibrate RPC, thesis §8.3.2): a
// second source looking at a Dirac at zero is read beside the stream, its calls interleaved
// with the stream's under the HDF5 lock, and the result is checked against the stream and
// written to a file that never replaces another.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/calibration.h"
#include "transient/service/pipeline.h"

namespace transient::service {

struct LiveCalibrationRequest {
  std::string source_uri;   // the source looking at a Dirac at zero
  int takes = 20;           // capture cycles averaged, 1..256
  std::string output_path;  // "" = no file
  // The stream it must fit (CheckCalibrationMatches), named in messages.
  std::string stream_uri;
  ScheduleOptions stream_schedule;
  ImageGeometry stream_geometry;
};

// Opens `request.source_uri` with `open` (under the HDF5 lock), averages its takes with the
// demodulator's outlier rejection, calling `on_take(done, total)` after each, and writes the
// file. Cancelled as soon as `cancelled()` returns true (checked between frames, at least every
// 100 ms); FailedPrecondition "<uri> does not fit the stream of <stream>: ..." for a table that
// does not fit; "output_path: ..." errors of the file (AlreadyExists for an existing one); the
// source's errors.
absl::StatusOr<CalibrationOutcome> MeasureLiveCalibration(
    const LiveCalibrationRequest& request, const SourceOpener& open,
    const std::function<void(int, int)>& on_take, const std::function<bool()>& cancelled);

}  // namespace transient::service

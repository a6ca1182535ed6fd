// The Calibrate RPC's measurement beside the stream.
#include "live_calibration.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/formats/atomic_output.h"
#include "transient/formats/calibration_file.h"
#include "transient/formats/hdf5_lock.h"
#include "transient/reconstruct/status_context.h"

namespace transient::service {
namespace {

// How often a calibration source waiting for its next frame looks at the cancel condition.
constexpr absl::Duration kCancelCheckInterval = absl::Milliseconds(100);

// The source of a Calibrate RPC: each call holds the HDF5 mutex only for itself (a replay reads
// HDF5), so the stream goes on meanwhile; Next fails with Cancelled once the client went away
// or the pipeline stops, so that neither waits for a calibration that cannot finish.
class CalibrationSource final : public CaptureSource {
 public:
  CalibrationSource(std::unique_ptr<CaptureSource> inner, std::function<bool()> cancelled)
      : inner_(std::move(inner)), cancelled_(std::move(cancelled)) {}
  const std::string& uri() const override { return inner_->uri(); }
  const CameraInfo& camera() const override { return inner_->camera(); }
  const AcquisitionSchedule& schedule() const override { return inner_->schedule(); }
  SourceCapabilities capabilities() const override { return inner_->capabilities(); }
  absl::Status Start() override {
    absl::MutexLock lock(&Hdf5Mutex());
    return inner_->Start();
  }
  absl::Status Stop() override {
    absl::MutexLock lock(&Hdf5Mutex());
    return inner_->Stop();
  }
  absl::Status Next(absl::Duration timeout, RawFrame* frame) override {
    // Short waits, so that cancellation is noticed within kCancelCheckInterval.
    const absl::Time end = absl::Now() + timeout;
    while (true) {
      if (cancelled_()) return absl::CancelledError("calibration cancelled");
      absl::Status status;
      {
        absl::MutexLock lock(&Hdf5Mutex());
        status = inner_->Next(std::min(kCancelCheckInterval, end - absl::Now()), frame);
      }
      if (!absl::IsDeadlineExceeded(status) || absl::Now() >= end) return status;
    }
  }

 private:
  std::unique_ptr<CaptureSource> inner_;
  std::function<bool()> cancelled_;
};

}  // namespace

absl::StatusOr<CalibrationOutcome> MeasureLiveCalibration(
    const LiveCalibrationRequest& request, const SourceOpener& open,
    const std::function<void(int, int)>& on_take, const std::function<bool()>& cancelled) {
  std::unique_ptr<CaptureSource> opened_source;
  {
    absl::MutexLock lock(&Hdf5Mutex());  // a replay source reads HDF5 when opened
    absl::StatusOr<std::unique_ptr<CaptureSource>> opened = open(request.source_uri);
    if (!opened.ok()) return opened.status();
    opened_source = *std::move(opened);
  }
  CalibrationSource source(std::move(opened_source), cancelled);
  absl::StatusOr<CalibrationCapture> measured =
      CaptureCalibration(source, request.takes, {.on_take = on_take});
  if (!measured.ok()) return measured.status();
  if (absl::Status status = CheckCalibrationMatches(measured->table, request.stream_schedule,
                                                    request.stream_geometry);
      !status.ok()) {
    return absl::FailedPreconditionError(absl::StrCat(request.source_uri,
                                                      " does not fit the stream of ",
                                                      request.stream_uri, ": ", status.message()));
  }
  if (!request.output_path.empty()) {
    // Never replaces a file, neither one made meanwhile nor one of a concurrent Calibrate.
    absl::Status status;
    {
      absl::MutexLock lock(&Hdf5Mutex());
      status =
          WriteCalibrationFile(request.output_path, measured->table, CommitMode::kNeverReplace);
    }
    if (!status.ok()) {
      return WithContext("output_path", status);
    }
  }
  return CalibrationOutcome{.table = std::move(measured->table),
                            .frames_rejected = measured->frames_rejected,
                            .usable_pixels = measured->usable_pixels};
}

}  // namespace transient::service

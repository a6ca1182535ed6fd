// Capture files, format `transient-capture 1`: the raw frames of a recording with their exposure
// metadata, the camera and the acquisition schedule, and optionally the simulator's ground truth
// and the calibration the capture is to be used with. Written frame by frame, crash-safe.
//
// Layout (HDF5; [..] are dataset shapes; N raw frames of H x W pixels; R returns per pixel):
//   /                       attribute format = "transient-capture 1" (string)
//                           attribute source_uri (string): where the frames came from
//   /camera                 attributes width, height (int64, pixels); fx, fy, cx, cy (float64,
//                           pixels); distortion (float64 [5]: k1, k2, p1, p2, k3, ROS
//                           plumb_bob); model (string); frame_period_s (float64, s; 0 = unknown)
//   /schedule               attributes base_frequency_hz (float64, Hz); order (int64, m);
//                           sampling (string: "four-bucket", "arccos", "harmonic-cancellation");
//                           phase_steps (int64, n_phi); zeroth (string: "pair", "proxy",
//                           "estimated"); proxy_frequency_hz (float64, Hz); exposure_s (float64,
//                           s); takes (int64); buckets (int64, N-step; absent = 4);
//                           harmonics (string "10,2,15", capture order; absent = 1..order);
//                           raw_frames_per_frame (int64, derived, checked)
//   /frames                 attribute saturation_level (float64, sensor units; inf = none)
//   /frames/pixels          uint16 or float32 [N, H, W], sensor units (DN), NaN = unreadable
//                           pixel (float32 only); chunked [1, H, W], optionally deflate+shuffle;
//                           extendible in N
//   /frames/harmonic        int32 [N]: j of c_j the exposure contributes to (0 = zeroth moment)
//   /frames/frequency_hz    float64 [N]: modulation frequency, Hz (0 = unmodulated)
//   /frames/phase_shift_rad float64 [N]: bucket phase shift, rad
//   /frames/exposure_s      float64 [N]: integration time, s
//   /frames/illumination    uint8 [N]: 1 = active illumination on, 0 = off
//   /frames/take            int32 [N]: take within the transient frame
//   /frames/cycle           int64 [N]: transient frame (capture cycle) of the raw frame
//   /frames/sequence        uint64 [N]: running number of the raw frame at its source
//   /frames/timestamp_s     float64 [N]: start of the exposure, s since the source started
//   /ground_truth           optional (simulated captures): first_range_m float32 [H, W] (m,
//                           NaN = no return); return_range_m, return_amplitude, return_spread_m
//                           float32 [R, H, W] (m, sensor units, m; NaN = unused);
//                           moments/real, moments/imag float32 [m+1, H, W] (true c_0..c_m)
//   /calibration            optional: the content of a calibration file (calibration_file.h):
//                           its root attributes and /factors/{real, imag, valid}
//
// The per-frame datasets are written with fill values no frame can hold (-1 for harmonic,
// take and cycle, 2^64-1 for sequence, 255 for illumination, NaN for the float64 ones): after a
// crash a reader counts frame i only when every per-frame value and the pixel chunk of frame i
// were written, and ignores the torn tail.
//
// Crash safety: the writer uses HDF5's single-writer/multiple-reader (SWMR) mode, which keeps
// the file's metadata consistent at every instant, and flushes at least every
// `flush_interval`. A recording killed at any moment keeps every frame written before its last
// flush. Such a file still carries SWMR's "open for writing" marks in its superblock: this
// reader opens it anyway (SWMR read), h5py with h5py.File(path, "r", swmr=True), and h5dump
// after `h5clear -s path`. A cleanly closed file opens everywhere as any HDF5 file.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/calibration.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/ground_truth.h"

namespace transient {

inline constexpr char kCaptureFormatName[] = "transient-capture";
inline constexpr int kCaptureFormatMajor = 1;

enum class CapturePixelType {
  kUint16,   // ADC counts: every value must be an integer in 0..65535 (exact, 2 bytes/pixel)
  kFloat32,  // any value, NaN included
};

struct CaptureWriterOptions {
  CapturePixelType pixel_type = CapturePixelType::kFloat32;
  int deflate_level = 0;  // 0 = uncompressed, 1..9 = deflate (with shuffle) of each frame
  // The longest a written frame waits before it is made durable (the flush happens in the
  // Append that finds the interval elapsed; call Flush() when frames stop coming).
  absl::Duration flush_interval = absl::Seconds(1);
  std::string source_uri = {};  // stored as the root attribute source_uri
  // Saturation level of every frame (RawFrame::saturation_level); frames must agree with it.
  float saturation_level = std::numeric_limits<float>::infinity();

  // "deflate_level = 12. Violated constraint: 0 <= deflate_level <= 9".
  absl::Status Validate() const;
};

// Appends raw frames to a new capture file. Not thread-safe; use from one thread.
class CaptureWriter {
 public:
  // Creates `path` (AlreadyExists if it exists: a recording never overwrites one) with the
  // camera, the schedule and the empty frame datasets, and closes it again: the file is
  // reopened in SWMR mode by the first Append or Flush, and until then SetGroundTruth and
  // EmbedCalibration add their groups to it. InvalidArgument for bad options or geometry;
  // FailedPrecondition, creating nothing, for a depth camera's schedule (SamplingScheme::kDepth):
  // the format holds modulated captures.
  [[nodiscard]] static absl::StatusOr<CaptureWriter> Create(const std::string& path,
                                                            const CameraInfo& camera,
                                                            const AcquisitionSchedule& schedule,
                                                            const CaptureWriterOptions& options);

  CaptureWriter(CaptureWriter&&) = default;
  CaptureWriter& operator=(CaptureWriter&&) = default;
  ~CaptureWriter();  // Close(), ignoring its status: call Close() to see it.

  // Appends `frame`. InvalidArgument when its geometry is not the camera's, its saturation
  // level not the options', a value does not fit uint16, or its metadata is not finite;
  // nothing is written then. Flushes when flush_interval has passed since the last flush.
  absl::Status Append(const RawFrame& frame);

  // Only before the first frame (FailedPrecondition after it: HDF5 1.10 cannot add objects to
  // a file in SWMR mode). Geometry must be the camera's (InvalidArgument); called twice, the
  // second replaces the first.
  absl::Status SetGroundTruth(const GroundTruth& truth);
  absl::Status EmbedCalibration(const CalibrationTable& calibration);

  // Makes every appended frame durable.
  absl::Status Flush();
  // Flushes and closes; the file then opens in any HDF5 reader. Further calls do nothing.
  // When the flush or close fails (a full disk), the error is returned and the file is
  // extended to the end HDF5 recorded (h5::ExtendToRecordedEnd): it still opens, with every
  // frame flushed before readable.
  absl::Status Close();

  const std::string& path() const { return path_; }
  int64_t frames() const { return frames_; }          // appended
  int64_t flushed_frames() const { return flushed_; }  // durable

 private:
  CaptureWriter() = default;
  absl::Status OpenForFrames();
  absl::Status CheckFrame(const RawFrame& frame) const;
  absl::Status WriteGroup(const char* name, const GroundTruth* truth,
                          const CalibrationTable* calibration);

  std::string path_;
  CameraInfo camera_;
  CaptureWriterOptions options_;
  h5::Id file_;  // open from the first frame on, in SWMR mode
  h5::Id pixels_;
  std::vector<h5::Id> metadata_;  // in the order of the per-frame datasets above
  int64_t frames_ = 0;
  int64_t flushed_ = 0;
  absl::Time last_flush_;
  bool closed_ = false;
};

// Reads a capture file, checking the whole layout at Open. Thread-compatible.
class CaptureReader {
 public:
  // Opens `path`, including a recording that was killed (the torn tail is not counted) or is
  // still being written (the frames flushed so far). Every message starts with the path and
  // names the object and the rule. NotFound, PermissionDenied, InvalidArgument (not HDF5,
  // another format such as "transient-moments 1", a missing or mis-typed or mis-shaped object),
  // DataLoss (HDF5 cannot open or read what the layout promises).
  [[nodiscard]] static absl::StatusOr<CaptureReader> Open(const std::string& path);

  CaptureReader(CaptureReader&&) = default;
  CaptureReader& operator=(CaptureReader&&) = default;

  const std::string& path() const { return path_; }
  const CameraInfo& camera() const { return camera_; }
  const AcquisitionSchedule& schedule() const { return *schedule_; }
  const std::string& source_uri() const { return source_uri_; }
  CapturePixelType pixel_type() const { return pixel_type_; }
  float saturation_level() const { return saturation_level_; }
  // Complete frames: every per-frame dataset and the pixels written (the minimum over them
  // after a crash).
  int64_t frames() const { return frames_; }
  // The exposure of frame `index` without reading its pixels.
  const ExposureConfig& config(int64_t index) const { return configs_[index]; }

  // Frame `index` (0 <= index < frames()), reusing `frame`'s buffers. OutOfRange outside,
  // DataLoss when its pixels cannot be read (corrupt chunk); other frames stay readable.
  absl::Status Read(int64_t index, RawFrame* frame) const;

  const std::optional<GroundTruth>& ground_truth() const { return ground_truth_; }
  const std::optional<CalibrationTable>& calibration() const { return calibration_; }

 private:
  CaptureReader() = default;
  absl::Status ReadLayout();
  absl::Status ReadFrameMetadata();

  std::string path_;
  h5::Id file_;
  h5::Id pixels_;
  CameraInfo camera_;
  std::optional<AcquisitionSchedule> schedule_;
  std::string source_uri_;
  CapturePixelType pixel_type_ = CapturePixelType::kFloat32;
  float saturation_level_ = std::numeric_limits<float>::infinity();
  int64_t frames_ = 0;
  std::vector<ExposureConfig> configs_;
  std::optional<GroundTruth> ground_truth_;
  std::optional<CalibrationTable> calibration_;
};

}  // namespace transient

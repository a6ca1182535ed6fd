// Writer of moment files, format `transient-moments 1` (layout in docs/formats/moments.md), one frame at a
// time: what `transient moments` produces from a capture and `transient reconstruct` reads.
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/image.h"

namespace transient {

struct MomentFileHeader {
  ImageGeometry geometry;
  int order = 0;                  // m
  double base_frequency_hz = 0.0;
  ZerothScheme zeroth = ZerothScheme::kUnmodulatedPair;  // kEstimated: plane 0 holds no c_0
  std::string source = {};        // what the moments came from (capture path), an attribute
  std::string calibration = {};   // the calibration applied ("" = none), an attribute
  double smoothing_sigma_px = 0;  // Gaussian smoothing applied, an attribute
};

class MomentFileWriter {
 public:
  // Creates (truncates) `path`: /moments/{real, imag} [frames, m+1, H, W] float32, /moments/valid
  // and /moments/flags uint8 [frames, H, W], /moments/timestamp_s float64 [frames], all
  // extendible and chunked one frame plane per chunk.
  [[nodiscard]] static absl::StatusOr<MomentFileWriter> Create(const std::string& path,
                                                               const MomentFileHeader& header);

  MomentFileWriter(MomentFileWriter&&) = default;
  MomentFileWriter& operator=(MomentFileWriter&&) = default;

  // Appends one frame; its geometry and order must be the header's.
  absl::Status Append(const MomentImage& moments, double timestamp_s);
  int64_t frames() const { return frames_; }
  // Flushes and closes; the file is complete only when this succeeded.
  absl::Status Close();

 private:
  MomentFileWriter() = default;

  std::string path_;
  MomentFileHeader header_;
  h5::Id file_, real_, imag_, valid_, flags_, timestamp_;
  int64_t frames_ = 0;
};

}  // namespace transient

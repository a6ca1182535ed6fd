// Reader of moment files, format `transient-moments 1` (layout in docs/formats/moments.md):
// a stack of trigonometric moment images c_0..c_m, read one frame at a time.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient {

inline constexpr char kMomentFormatName[] = "transient-moments";
inline constexpr int kMomentFormatMajor = 1;

class MomentFile {
 public:
  // Opens `path` and checks the whole layout (format, datasets, types, shapes, attributes)
  // before any frame is read. Every error message starts with the path as given and names
  // the object and the rule, e.g. "in.h5: /moments/real: expected 4 dimensions
  // [frames, m+1, height, width], found 3". Codes: NotFound (no such file),
  // PermissionDenied (unreadable), InvalidArgument (not HDF5, wrong layout), DataLoss
  // (HDF5 cannot open what it should be able to).
  [[nodiscard]] static absl::StatusOr<MomentFile> Open(const std::string& path);

  MomentFile(MomentFile&&) = default;
  MomentFile& operator=(MomentFile&&) = default;

  const std::string& path() const { return path_; }
  int64_t frames() const { return frames_; }
  int order() const { return order_; }  // m, 1 <= m <= kMaxOrder
  ImageGeometry geometry() const { return geometry_; }
  double base_frequency_hz() const { return base_frequency_hz_; }  // > 0 and finite
  bool has_valid_mask() const { return valid_.valid(); }
  bool has_flags() const { return flags_.valid(); }
  // How the file says c_0 was obtained (attribute /moments zeroth, "measured" or "estimated",
  // written by `transient moments`); nullopt when the file does not say.
  std::optional<ZerothMoment> zeroth_hint() const { return zeroth_hint_; }

  // Reads frame `frame` (0 <= frame < frames()) into `image`, reusing its buffers. float64
  // data is converted to float32. `image->valid` (`image->flags`) is left empty when the file
  // has no /moments/valid (/moments/flags).
  // DataLoss when HDF5 cannot read the frame (a corrupt or truncated file).
  absl::Status ReadFrame(int64_t frame, MomentImage* image) const;

 private:
  MomentFile() = default;

  std::string path_;
  h5::Id file_;
  h5::Id real_;
  h5::Id imag_;
  h5::Id valid_;  // not valid() when the file has no /moments/valid
  h5::Id flags_;  // not valid() when the file has no /moments/flags
  std::optional<ZerothMoment> zeroth_hint_;
  int64_t frames_ = 0;
  int order_ = 0;
  ImageGeometry geometry_;
  double base_frequency_hz_ = 0.0;
};

}  // namespace transient

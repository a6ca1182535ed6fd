// Reader of reconstruction files, format `transient-reconstruction 1` (layout in docs/formats/reconstruction.md,
// written by ReconstructionFile): checks the whole layout at Open, then reads the products a
// caller asks for one frame at a time into a TransientFrame.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/formats/reconstruction_file.h"
#include "transient/formats/transient_frame.h"
#include "transient/formats/h5.h"

namespace transient {

class ReconstructionReader : public TransientFrameSource {
 public:
  // Opens `path` and checks the format attribute, the root attributes it needs
  // (base_frequency_hz, bins, order, method; threshold and bounds_r when present) and every
  // dataset the method promises: its type (float, flags uint8), its shape ([frames, H, W] or
  // [frames, planes, H, W] with the planes the attributes say) and its filters. Messages start
  // with the path and name the object and the rule, e.g. "r.h5: /density: expected shape
  // [frames, bins, height, width] = [2, 64, 12, 16], found [2, 32, 12, 16]". Codes: NotFound,
  // PermissionDenied, InvalidArgument (not HDF5, another format, a broken layout), DataLoss
  // (HDF5 cannot open what it should).
  [[nodiscard]] static absl::StatusOr<ReconstructionReader> Open(const std::string& path);

  ReconstructionReader(ReconstructionReader&&) = default;
  ReconstructionReader& operator=(ReconstructionReader&&) = default;

  const std::string& path() const { return path_; }
  const std::string& name() const override { return path_; }
  int64_t frames() const override { return frames_; }
  ImageGeometry geometry() const override { return geometry_; }
  int order() const { return order_; }
  double base_frequency_hz() const override { return base_frequency_hz_; }
  int bins() const override { return static_cast<int>(phases_.size()); }
  // Index in the moment file of frame 0 (attribute first_frame; 0 when absent).
  int64_t first_frame() const { return first_frame_; }
  const std::string& method() const { return method_; }
  const std::vector<double>& phases() const { return phases_; }  // empty without bins products
  std::optional<double> bounds_r() const { return bounds_r_; }
  bool has(Product product) const { return datasets_[static_cast<int>(product)].valid(); }
  ProductSet available() const override;

  // Reads the products `wanted` of frame `frame` (0 <= frame < frames()) into `out`, reusing
  // its buffers; the planes of products not wanted (or not in the file) are left empty.
  // NotFound naming the dataset when a wanted product is not in the file, OutOfRange for a
  // frame outside the file, DataLoss when HDF5 cannot read it (a corrupt or truncated file).
  absl::Status ReadFrame(int64_t frame, ProductSet wanted, TransientFrame* out) const override;

 private:
  ReconstructionReader() = default;

  std::string path_;
  h5::Id file_;
  std::vector<h5::Id> datasets_ = std::vector<h5::Id>(kProductCount);
  std::vector<int> planes_ = std::vector<int>(kProductCount, 0);
  int64_t frames_ = 0;
  ImageGeometry geometry_;
  int order_ = 0;
  double base_frequency_hz_ = 0.0;
  double threshold_ = 0.1;
  int64_t first_frame_ = 0;
  std::string method_;
  std::vector<double> phases_;
  std::optional<double> bounds_r_;
};

// The dataset path of a product ("/density", "/pisarenko/weight").
const char* ProductPath(Product product);

}  // namespace transient

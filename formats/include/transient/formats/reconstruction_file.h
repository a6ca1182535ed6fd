// Writer of reconstruction files, format `transient-reconstruction 1` (layout in
// docs/formats/reconstruction.md): per-frame product stacks, chunked and written one frame at a time.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/units.h"

namespace transient {

inline constexpr char kReconstructionFormatName[] = "transient-reconstruction";
inline constexpr int kReconstructionFormatMajor = 1;

// The datasets of a reconstruction file. Each is a stack over frames of `planes` images:
// [frames, H, W] when a frame has one plane, [frames, planes, H, W] otherwise.
enum class Product {
  kRange,              // /range_m, float32
  kZerothMoment,       // /c0, float32
  kFlags,              // /flags, uint8 PixelFlag bits
  kDensity,            // /density, float32, bins planes
  kCumulative,         // /cumulative, float32, bins planes
  kPisarenkoPhase,     // /pisarenko/phase, float32, m planes
  kPisarenkoWeight,    // /pisarenko/weight, float32, m planes
  kPisarenkoUniform,   // /pisarenko/uniform, float32
  kPisarenkoRange,     // /pisarenko/range_m, float32
  kPisarenkoDirect,    // /pisarenko/direct, float32
  kPisarenkoIndirect,  // /pisarenko/indirect, float32
  kBoundsLower,        // /bounds/lower, float32, bins planes
  kBoundsUpper,        // /bounds/upper, float32, bins planes
};
inline constexpr int kProductCount = 13;

// How many image planes a product has per frame: one, one per bin phase, or one per moment
// order (the m Pisarenko returns).
enum class ProductPlanes { kOne, kBins, kOrder };

// Which settings a product comes with: always, with MESE (method mese or both), with
// Pisarenko (method pisarenko or both), or with bounds (bounds_r set; optional for a reader).
enum class ProductGroup { kAlways, kMese, kPisarenko, kBounds };

// Where and how a product is stored: the one place that names the datasets, shared by the
// writer and the reader; docs/formats/reconstruction.md documents the same table.
struct ProductLayout {
  Product product;
  const char* path;
  ProductPlanes planes;
  ProductGroup group;
  const char* units;  // the dataset's `units` attribute (units.h)
};

inline constexpr std::array<ProductLayout, kProductCount> kProductLayouts = {{
    {Product::kRange, "/range_m", ProductPlanes::kOne, ProductGroup::kAlways, units::kMetres},
    {Product::kZerothMoment, "/c0", ProductPlanes::kOne, ProductGroup::kAlways, units::kSensor},
    {Product::kFlags, "/flags", ProductPlanes::kOne, ProductGroup::kAlways, units::kBits},
    {Product::kDensity, "/density", ProductPlanes::kBins, ProductGroup::kMese,
     units::kSensorPerRadian},
    {Product::kCumulative, "/cumulative", ProductPlanes::kBins, ProductGroup::kMese,
     units::kSensor},
    {Product::kPisarenkoPhase, "/pisarenko/phase", ProductPlanes::kOrder, ProductGroup::kPisarenko,
     units::kRadians},
    {Product::kPisarenkoWeight, "/pisarenko/weight", ProductPlanes::kOrder,
     ProductGroup::kPisarenko, units::kSensor},
    {Product::kPisarenkoUniform, "/pisarenko/uniform", ProductPlanes::kOne,
     ProductGroup::kPisarenko, units::kSensor},
    {Product::kPisarenkoRange, "/pisarenko/range_m", ProductPlanes::kOne, ProductGroup::kPisarenko,
     units::kMetres},
    {Product::kPisarenkoDirect, "/pisarenko/direct", ProductPlanes::kOne, ProductGroup::kPisarenko,
     units::kSensor},
    {Product::kPisarenkoIndirect, "/pisarenko/indirect", ProductPlanes::kOne,
     ProductGroup::kPisarenko, units::kSensor},
    {Product::kBoundsLower, "/bounds/lower", ProductPlanes::kBins, ProductGroup::kBounds,
     units::kSensorPerRadian},
    {Product::kBoundsUpper, "/bounds/upper", ProductPlanes::kBins, ProductGroup::kBounds,
     units::kSensorPerRadian},
}};

constexpr bool ProductLayoutsAreInEnumOrder() {
  for (int i = 0; i < kProductCount; ++i) {
    if (static_cast<int>(kProductLayouts[i].product) != i) return false;
  }
  return true;
}
static_assert(ProductLayoutsAreInEnumOrder(), "kProductLayouts is indexed by Product");

// float64 [bins]: the phases of the bins planes (density, cumulative, bounds), rad.
inline constexpr char kPhasesPath[] = "/phase_rad";

// Planes per frame of a product in a file of `bins` bins and order m.
int PlaneCount(ProductPlanes planes, int bins, int order);

// The block of a product's dataset that holds planes [first_plane, first_plane + planes) of
// frame `frame`: its start and its count, [frame, H, W]-shaped for one-plane products and
// [frame, planes, H, W]-shaped for stacks.
struct ProductBlock {
  std::vector<hsize_t> start;
  std::vector<hsize_t> count;
};
ProductBlock BlockOf(const ProductLayout& layout, int64_t frame, int first_plane, int planes,
                     ImageGeometry geometry);

// What a file holds and the settings recorded in its root attributes.
struct ReconstructionHeader {
  int64_t frames = 0;  // frames written (those selected by --frames)
  int order = 0;       // m of the input
  ImageGeometry geometry = {};
  std::vector<double> phases = {};  // the bins phases of /density, /cumulative and /bounds
  bool mese = true;                 // /density, /cumulative and /phase_rad
  bool pisarenko = true;            // the /pisarenko group
  std::optional<double> bounds_r = std::nullopt;  // the /bounds group when set, r in (0, 1)

  double base_frequency_hz = 0.0;
  std::string method = {};  // "mese", "pisarenko" or "both"
  double bias_epsilon = 0.0;
  std::string bias_mode = {};  // "raise" or "scale"
  std::string zeroth = {};     // "measured" or "estimate"
  double threshold = 0.0;
  int64_t first_frame = 0;  // index in the input file of output frame 0
  std::string source = {};  // the input file as named on the command line
};

class ReconstructionFile {
 public:
  // Creates (truncates) `path` with every dataset of `header` and the root attributes.
  // Datasets are chunked one image plane per chunk and filled with NaN (flags with 0).
  [[nodiscard]] static absl::StatusOr<ReconstructionFile> Create(
      const std::string& path, const ReconstructionHeader& header);

  ReconstructionFile(ReconstructionFile&&) = default;
  ReconstructionFile& operator=(ReconstructionFile&&) = default;

  bool has(Product product) const { return datasets_[Index(product)].valid(); }

  // Writes planes [first_plane, first_plane + planes.size() / pixel_count) of frame `frame`.
  // `planes` is planar, row-major, one image after the other.
  absl::Status Write(Product product, int64_t frame, int first_plane,
                     std::span<const float> planes);
  // Writes the one plane of /flags of frame `frame`.
  absl::Status WriteFlags(int64_t frame, std::span<const uint8_t> flags);

  // Closes every dataset and the file and reports a failed flush. Nothing may be written
  // afterwards.
  absl::Status Close();

 private:
  ReconstructionFile() = default;
  static int Index(Product product) { return static_cast<int>(product); }
  absl::Status WritePlanes(Product product, int64_t frame, int first_plane, int64_t values,
                           hid_t memory_type, const void* data);

  std::string path_;
  h5::Id file_;
  std::array<h5::Id, kProductCount> datasets_;
  std::array<int, kProductCount> planes_{};  // planes per frame of each dataset
  ImageGeometry geometry_;
  int64_t frames_ = 0;
};

}  // namespace transient

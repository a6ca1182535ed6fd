// Layout checks and frame-by-frame hyperslab reads of `transient-reconstruction 1` files.
#include "transient/formats/reconstruction_reader.h"

#include <cstdint>
#include <numbers>
#include <utility>

#include "absl/strings/str_cat.h"
#include "transient/formats/format_tag.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

using h5::Where;

// /flags holds PixelFlag bits in one unsigned byte (not h5py's bool enum, which reads back as
// no integer type).
constexpr h5::TypeRule kFlagsType{H5T_INTEGER, 1, "uint8"};
// /phase_rad is written as float64; float32 reads as well.
constexpr h5::TypeRule kPhasesType{H5T_FLOAT, 0, "float64"};
// Bounds of counts in the root attributes, far beyond any file `transient reconstruct` writes,
// so that a corrupt value is named rather than overflowing.
constexpr int64_t kMaxBins = int64_t{1} << 20;
constexpr int64_t kMaxFirstFrame = int64_t{1} << 53;

// Whether a file written with `method` must have the products of `group`; the bounds are
// optional (as a pair).
bool Required(ProductGroup group, const std::string& method) {
  switch (group) {
    case ProductGroup::kAlways:
      return true;
    case ProductGroup::kMese:
      return method != "pisarenko";
    case ProductGroup::kPisarenko:
      return method != "mese";
    case ProductGroup::kBounds:
      return false;
  }
  return false;
}

const char* ShapeName(ProductPlanes planes) {
  switch (planes) {
    case ProductPlanes::kOne:
      return "[frames, height, width]";
    case ProductPlanes::kBins:
      return "[frames, bins, height, width]";
    case ProductPlanes::kOrder:
      return "[frames, m, height, width]";
  }
  return "";
}

}  // namespace

const char* ProductPath(Product product) { return kProductLayouts[static_cast<int>(product)].path; }

ProductSet ReconstructionReader::available() const {
  ProductSet set;
  for (int i = 0; i < kProductCount; ++i) set[i] = datasets_[i].valid();
  return set;
}

absl::StatusOr<ReconstructionReader> ReconstructionReader::Open(const std::string& path) {
  absl::StatusOr<h5::Id> file = h5::OpenFileForReading(path, "an HDF5 reconstruction file");
  if (!file.ok()) return file.status();
  ReconstructionReader reader;
  reader.path_ = path;
  reader.file_ = *std::move(file);
  const hid_t id = reader.file_.get();
  const std::string root = Where(path, "/");

  if (absl::Status status =
          ReadFormatAttribute(id, root, kReconstructionFormatName, kReconstructionFormatMajor);
      !status.ok()) {
    return status;
  }
  absl::StatusOr<double> frequency =
      h5::ReadFiniteAttribute(id, "base_frequency_hz", root, h5::Sign::kPositive);
  if (!frequency.ok()) return frequency.status();
  reader.base_frequency_hz_ = *frequency;
  absl::StatusOr<int64_t> order = h5::ReadIntegerAttribute(id, "order", root, 1, kMaxOrder);
  if (!order.ok()) return order.status();
  reader.order_ = static_cast<int>(*order);
  absl::StatusOr<int64_t> bins = h5::ReadIntegerAttribute(id, "bins", root, 1, kMaxBins);
  if (!bins.ok()) return bins.status();
  absl::StatusOr<std::string> method = h5::ReadStringAttribute(id, "method", root);
  if (!method.ok()) return method.status();
  if (*method != "mese" && *method != "pisarenko" && *method != "both") {
    return absl::InvalidArgumentError(absl::StrCat(
        root, ": attribute method: expected 'mese', 'pisarenko' or 'both', found '", *method, "'"));
  }
  reader.method_ = *method;
  if (H5Aexists(id, "threshold") > 0) {
    absl::StatusOr<double> threshold = h5::ReadNumericAttribute(id, "threshold", root);
    if (!threshold.ok()) return threshold.status();
    if (!(*threshold >= 0.0 && *threshold < 1.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat(root, ": attribute threshold: expected 0 <= T < 1, found ", *threshold));
    }
    reader.threshold_ = *threshold;
  }
  if (H5Aexists(id, "first_frame") > 0) {
    absl::StatusOr<int64_t> first =
        h5::ReadIntegerAttribute(id, "first_frame", root, 0, kMaxFirstFrame);
    if (!first.ok()) return first.status();
    reader.first_frame_ = *first;
  }

  // /range_m, the first of the table, fixes frames, height and width for every other dataset.
  std::vector<hsize_t> frame_shape;
  for (const ProductLayout& spec : kProductLayouts) {
    const int index = static_cast<int>(spec.product);
    if (!h5::LinkExists(id, spec.path)) {
      if (Required(spec.group, reader.method_)) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": missing dataset ", spec.path, " (float32 ",
                         ShapeName(spec.planes), ", written for method '", reader.method_, "')"));
      }
      continue;
    }
    const bool stacked = spec.planes != ProductPlanes::kOne;
    std::vector<hsize_t> dims;
    absl::StatusOr<h5::Id> dataset = h5::OpenDataset(
        id, path, spec.path, spec.product == Product::kFlags ? kFlagsType : h5::kAnyFloat,
        stacked ? 4 : 3, ShapeName(spec.planes), &dims);
    if (!dataset.ok()) return dataset.status();
    const std::string where = Where(path, spec.path);
    if (frame_shape.empty()) {
      if (dims[0] == 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": expected at least 1 frame, found 0"));
      }
      if (absl::Status status = h5::CheckImageSize(where, dims[1], dims[2]); !status.ok()) {
        return status;
      }
      frame_shape = dims;
    }
    const ImageGeometry geometry = {.width = static_cast<int>(frame_shape[2]),
                                    .height = static_cast<int>(frame_shape[1])};
    const int planes = PlaneCount(spec.planes, static_cast<int>(*bins), reader.order_);
    std::vector<hsize_t> expected = BlockOf(spec, 0, 0, planes, geometry).count;
    expected[0] = frame_shape[0];
    if (absl::Status status = h5::CheckShape(where, dims, expected, ShapeName(spec.planes));
        !status.ok()) {
      return status;
    }
    reader.datasets_[index] = *std::move(dataset);
    reader.planes_[index] = planes;
  }
  reader.frames_ = static_cast<int64_t>(frame_shape[0]);
  reader.geometry_ = {.width = static_cast<int>(frame_shape[2]),
                      .height = static_cast<int>(frame_shape[1])};

  if (reader.has(Product::kBoundsLower) != reader.has(Product::kBoundsUpper)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": expected both /bounds/lower and /bounds/upper or neither, found ",
                     reader.has(Product::kBoundsLower) ? "only lower" : "only upper"));
  }
  if (reader.has(Product::kBoundsLower)) {
    absl::StatusOr<double> r = h5::ReadNumericAttribute(id, "bounds_r", root);
    if (!r.ok()) return r.status();
    if (!(*r > 0.0 && *r < 1.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat(root, ": attribute bounds_r: expected 0 < r < 1, found ", *r));
    }
    reader.bounds_r_ = *r;
  }
  if (reader.has(Product::kDensity) || reader.has(Product::kBoundsLower)) {
    std::vector<hsize_t> dims;
    absl::StatusOr<h5::Id> phases =
        h5::OpenDataset(id, path, kPhasesPath, kPhasesType, 1, "[bins]", &dims);
    if (!phases.ok()) return phases.status();
    const std::string where = Where(path, kPhasesPath);
    if (absl::Status status = h5::CheckShape(where, dims, {static_cast<hsize_t>(*bins)}, "[bins]");
        !status.ok()) {
      return status;
    }
    reader.phases_.resize(*bins);
    if (absl::Status status =
            h5::ReadDataset(phases->get(), H5T_NATIVE_DOUBLE, reader.phases_.data(), where);
        !status.ok()) {
      return status;
    }
    for (size_t n = 0; n < reader.phases_.size(); ++n) {
      const double phi = reader.phases_[n];
      if (!(phi >= 0.0 && phi <= 2.0 * std::numbers::pi) ||
          (n > 0 && !(phi > reader.phases_[n - 1]))) {
        return absl::InvalidArgumentError(absl::StrCat(
            where, ": expected ascending phases in [0, 2*pi], found ", phi, " at index ", n));
      }
    }
  }
  return reader;
}

absl::Status ReconstructionReader::ReadFrame(int64_t frame, ProductSet wanted,
                                             TransientFrame* out) const {
  if (frame < 0 || frame >= frames_) {
    return absl::OutOfRangeError(
        absl::StrCat(path_, ": frame ", frame, " is outside 0..", frames_ - 1));
  }
  out->geometry = geometry_;
  out->order = order_;
  out->base_frequency_hz = base_frequency_hz_;
  out->index = frame;
  out->threshold = threshold_;
  out->phases = phases_;
  out->bounds_r = bounds_r_;
  std::vector<float>* const float_planes[kProductCount] = {
      &out->range_m,
      &out->c0,
      nullptr,
      &out->density,
      &out->cumulative,
      &out->pisarenko_phase,
      &out->pisarenko_weight,
      &out->pisarenko_uniform,
      &out->pisarenko_range_m,
      &out->pisarenko_direct,
      &out->pisarenko_indirect,
      &out->bounds_lower,
      &out->bounds_upper,
  };
  const int64_t pixels = geometry_.pixel_count();
  for (const ProductLayout& spec : kProductLayouts) {
    const int index = static_cast<int>(spec.product);
    const bool is_flags = spec.product == Product::kFlags;
    if (!wanted[index]) {
      if (is_flags) {
        out->flags.clear();
      } else {
        float_planes[index]->clear();
      }
      continue;
    }
    if (!has(spec.product)) {
      const bool bounds = spec.group == ProductGroup::kBounds;
      return absl::NotFoundError(
          absl::StrCat(path_, ": has no dataset ", spec.path, " (method '", method_, "'",
                       bounds ? "; transient reconstruct --bounds-r R writes /bounds" : "", ")"));
    }
    const int planes = planes_[index];
    void* buffer = nullptr;
    if (is_flags) {
      out->flags.resize(pixels);
      buffer = out->flags.data();
    } else {
      float_planes[index]->resize(planes * pixels);
      buffer = float_planes[index]->data();
    }
    const ProductBlock block = BlockOf(spec, frame, 0, planes, geometry_);
    if (!h5::ReadBlock(datasets_[index].get(), block.start, block.count,
                       is_flags ? H5T_NATIVE_UINT8 : H5T_NATIVE_FLOAT, buffer)
             .ok()) {
      return absl::DataLossError(
          absl::StrCat(path_, ": ", spec.path, ": cannot read frame ", frame, " (corrupt file?)"));
    }
  }
  return absl::OkStatus();
}

}  // namespace transient

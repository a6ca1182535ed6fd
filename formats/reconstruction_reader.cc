// Layout checks and frame-by-frame hyperslab reads of `transient-reconstruction 1` files.
#include "transient/formats/reconstruction_reader.h"

#include <cmath>
#include <limits>
#include <numbers>

#include "absl/strings/str_cat.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/format_tag.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

// Whether the file must have `product`: the method decides MESE and Pisarenko products, the
// bounds are optional (as a pair).
bool Required(Product product, const std::string& method) {
  switch (product) {
    case Product::kRange:
    case Product::kZerothMoment:
    case Product::kFlags:
      return true;
    case Product::kDensity:
    case Product::kCumulative:
      return method != "pisarenko";
    case Product::kPisarenkoPhase:
    case Product::kPisarenkoWeight:
    case Product::kPisarenkoUniform:
    case Product::kPisarenkoRange:
    case Product::kPisarenkoDirect:
    case Product::kPisarenkoIndirect:
      return method != "mese";
    case Product::kBoundsLower:
    case Product::kBoundsUpper:
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

absl::StatusOr<int64_t> ReadPositiveInteger(hid_t object, const char* name,
                                            const std::string& where, int64_t max) {
  absl::StatusOr<double> value = h5::ReadNumericAttribute(object, name, where);
  if (!value.ok()) return value.status();
  if (!(*value >= 1.0 && *value <= static_cast<double>(max)) || std::floor(*value) != *value) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": attribute ", name,
                                                   ": expected an integer in 1..", max,
                                                   ", found ", *value));
  }
  return static_cast<int64_t>(*value);
}

}  // namespace

const char* ProductPath(Product product) { return kProductLayouts[static_cast<int>(product)].path; }

ProductSet Products(std::initializer_list<Product> products) {
  ProductSet set;
  for (Product product : products) set.set(static_cast<int>(product));
  return set;
}

ProductSet ReconstructionReader::available() const {
  ProductSet set;
  for (int i = 0; i < kProductCount; ++i) set[i] = datasets_[i].valid();
  return set;
}

absl::StatusOr<ReconstructionReader> ReconstructionReader::Open(const std::string& path) {
  h5::SilenceErrorStack();
  if (absl::Status readable = h5::CheckReadableFile(path, "an HDF5 reconstruction file");
      !readable.ok()) {
    return readable;
  }
  ReconstructionReader reader;
  reader.path_ = path;
  reader.file_ = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!reader.file_.valid()) {
    return absl::DataLossError(
        absl::StrCat(path, ": HDF5 cannot open the file (corrupt, truncated or locked)"));
  }
  const hid_t id = reader.file_.get();
  const std::string root = absl::StrCat(path, ": /");

  absl::StatusOr<std::string> format = h5::ReadStringAttribute(id, "format", root);
  if (!format.ok()) return format.status();
  if (absl::Status tag =
          CheckFormatTag(*format, kReconstructionFormatName, kReconstructionFormatMajor);
      !tag.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(root, ": attribute format: ", tag.message()));
  }

  absl::StatusOr<double> frequency = h5::ReadNumericAttribute(id, "base_frequency_hz", root);
  if (!frequency.ok()) return frequency.status();
  if (!std::isfinite(*frequency) || *frequency <= 0.0) {
    return absl::InvalidArgumentError(absl::StrCat(
        root, ": attribute base_frequency_hz: expected a finite value > 0, found ", *frequency));
  }
  reader.base_frequency_hz_ = *frequency;
  absl::StatusOr<int64_t> order = ReadPositiveInteger(id, "order", root, kMaxOrder);
  if (!order.ok()) return order.status();
  reader.order_ = static_cast<int>(*order);
  absl::StatusOr<int64_t> bins = ReadPositiveInteger(id, "bins", root, 1 << 20);
  if (!bins.ok()) return bins.status();
  absl::StatusOr<std::string> method = h5::ReadStringAttribute(id, "method", root);
  if (!method.ok()) return method.status();
  if (*method != "mese" && *method != "pisarenko" && *method != "both") {
    return absl::InvalidArgumentError(absl::StrCat(
        root, ": attribute method: expected 'mese', 'pisarenko' or 'both', found '", *method,
        "'"));
  }
  reader.method_ = *method;
  if (H5Aexists(id, "threshold") > 0) {
    absl::StatusOr<double> threshold = h5::ReadNumericAttribute(id, "threshold", root);
    if (!threshold.ok()) return threshold.status();
    if (!(*threshold >= 0.0 && *threshold < 1.0)) {
      return absl::InvalidArgumentError(absl::StrCat(
          root, ": attribute threshold: expected 0 <= T < 1, found ", *threshold));
    }
    reader.threshold_ = *threshold;
  }
  if (H5Aexists(id, "first_frame") > 0) {
    absl::StatusOr<double> first = h5::ReadNumericAttribute(id, "first_frame", root);
    if (!first.ok()) return first.status();
    if (!(*first >= 0.0 && *first < 9.0e15) || std::floor(*first) != *first) {
      return absl::InvalidArgumentError(absl::StrCat(
          root, ": attribute first_frame: expected an integer >= 0, found ", *first));
    }
    reader.first_frame_ = static_cast<int64_t>(*first);
  }

  // /range_m fixes frames, height and width for every other dataset.
  std::vector<hsize_t> frame_shape;
  for (const ProductLayout& spec : kProductLayouts) {
    const bool present = h5::LinkExists(id, spec.path);
    if (!present) {
      if (Required(spec.product, reader.method_)) {
        return absl::InvalidArgumentError(absl::StrCat(
            path, ": missing dataset ", spec.path, " (float32 ", ShapeName(spec.planes),
            ", written for method '", reader.method_, "')"));
      }
      continue;
    }
    absl::StatusOr<h5::Id> dataset = h5::OpenObject(
        id, path, spec.path, H5I_DATASET, absl::StrCat("dataset ", ShapeName(spec.planes)));
    if (!dataset.ok()) return dataset.status();
    const std::string where = absl::StrCat(path, ": ", spec.path);
    h5::Id type = h5::Datatype(H5Dget_type(dataset->get()));
    if (spec.product == Product::kFlags) {
      if (H5Tget_class(type.get()) != H5T_INTEGER || H5Tget_size(type.get()) != 1) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": expected uint8, found ", h5::DescribeType(type.get())));
      }
    } else if (H5Tget_class(type.get()) != H5T_FLOAT) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": expected float32 or float64, found ",
                                                     h5::DescribeType(type.get())));
    }
    h5::Id space = h5::Dataspace(H5Dget_space(dataset->get()));
    const std::vector<hsize_t> dims = h5::Dimensions(space.get());
    const int planes = spec.planes == ProductPlanes::kOne    ? 1
                       : spec.planes == ProductPlanes::kBins ? static_cast<int>(*bins)
                                                      : reader.order_;
    if (frame_shape.empty()) {  // /range_m, the first of the table
      if (dims.size() != 3) {
        return absl::InvalidArgumentError(absl::StrCat(
            where, ": expected 3 dimensions [frames, height, width], found ", dims.size()));
      }
      if (dims[0] == 0 || dims[1] == 0 || dims[2] == 0) {
        return absl::InvalidArgumentError(absl::StrCat(
            where, ": expected at least one frame of at least 1x1 px, found ",
            h5::DimensionsToString(dims)));
      }
      if (dims[1] * dims[2] > kMaxImagePixels) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": expected at most ",
                                                       kMaxImagePixels, " pixels per image, found ",
                                                       dims[1], " x ", dims[2]));
      }
      frame_shape = dims;
    }
    const std::vector<hsize_t> expected =
        spec.planes == ProductPlanes::kOne
            ? frame_shape
            : std::vector<hsize_t>{frame_shape[0], static_cast<hsize_t>(planes), frame_shape[1],
                                   frame_shape[2]};
    if (dims != expected) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": expected shape ",
                                                     ShapeName(spec.planes), " = ",
                                                     h5::DimensionsToString(expected), ", found ",
                                                     h5::DimensionsToString(dims)));
    }
    if (absl::Status status = h5::CheckFiltersAvailable(dataset->get(), where); !status.ok()) {
      return status;
    }
    reader.datasets_[static_cast<int>(spec.product)] = *std::move(dataset);
    reader.planes_[static_cast<int>(spec.product)] = planes;
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
    absl::StatusOr<h5::Id> phases = h5::OpenObject(id, path, "/phase_rad", H5I_DATASET,
                                                   "dataset /phase_rad (float64, [bins])");
    if (!phases.ok()) return phases.status();
    const std::string where = absl::StrCat(path, ": /phase_rad");
    h5::Id type = h5::Datatype(H5Dget_type(phases->get()));
    h5::Id space = h5::Dataspace(H5Dget_space(phases->get()));
    const std::vector<hsize_t> dims = h5::Dimensions(space.get());
    if (H5Tget_class(type.get()) != H5T_FLOAT) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": expected float64, found ", h5::DescribeType(type.get())));
    }
    if (dims != std::vector<hsize_t>{static_cast<hsize_t>(*bins)}) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": expected shape [bins] = [", *bins,
                                                     "], found ", h5::DimensionsToString(dims)));
    }
    reader.phases_.resize(*bins);
    if (H5Dread(phases->get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                reader.phases_.data()) < 0) {
      return absl::DataLossError(absl::StrCat(where, ": cannot be read (corrupt file?)"));
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
      &out->range_m,           &out->c0,
      nullptr,                 &out->density,
      &out->cumulative,        &out->pisarenko_phase,
      &out->pisarenko_weight,  &out->pisarenko_uniform,
      &out->pisarenko_range_m, &out->pisarenko_direct,
      &out->pisarenko_indirect, &out->bounds_lower,
      &out->bounds_upper,
  };
  const hsize_t height = geometry_.height, width = geometry_.width;
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
      const bool bounds =
          spec.product == Product::kBoundsLower || spec.product == Product::kBoundsUpper;
      return absl::NotFoundError(
          absl::StrCat(path_, ": has no dataset ", spec.path, " (method '", method_, "'",
                       bounds ? "; transient reconstruct --bounds-r R writes /bounds" : "", ")"));
    }
    const int planes = planes_[index];
    const bool stacked = spec.planes != ProductPlanes::kOne;
    const std::vector<hsize_t> start =
        stacked ? std::vector<hsize_t>{static_cast<hsize_t>(frame), 0, 0, 0}
                : std::vector<hsize_t>{static_cast<hsize_t>(frame), 0, 0};
    const std::vector<hsize_t> count =
        stacked ? std::vector<hsize_t>{1, static_cast<hsize_t>(planes), height, width}
                : std::vector<hsize_t>{1, height, width};
    void* buffer = nullptr;
    if (is_flags) {
      out->flags.resize(pixels);
      buffer = out->flags.data();
    } else {
      float_planes[index]->resize(planes * pixels);
      buffer = float_planes[index]->data();
    }
    const hid_t dataset = datasets_[index].get();
    h5::Id memory =
        h5::Dataspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr));
    h5::Id selection = h5::Dataspace(H5Dget_space(dataset));
    if (H5Sselect_hyperslab(selection.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(),
                            nullptr) < 0 ||
        H5Dread(dataset, is_flags ? H5T_NATIVE_UINT8 : H5T_NATIVE_FLOAT, memory.get(),
                selection.get(), H5P_DEFAULT, buffer) < 0) {
      return absl::DataLossError(
          absl::StrCat(path_, ": ", spec.path, ": cannot read frame ", frame, " (corrupt file?)"));
    }
  }
  return absl::OkStatus();
}

}  // namespace transient

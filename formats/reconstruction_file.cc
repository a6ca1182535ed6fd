// Dataset layout and frame-by-frame hyperslab writes of `transient-reconstruction 1` files.
#include "transient/formats/reconstruction_file.h"

#include <limits>

#include "absl/strings/str_cat.h"
#include "transient/formats/format_tag.h"
#include "transient/reconstruct/status_context.h"

namespace transient {
namespace {

// Whether a file written with `header` holds the products of `group`.
bool Written(ProductGroup group, const ReconstructionHeader& header) {
  switch (group) {
    case ProductGroup::kAlways:
      return true;
    case ProductGroup::kMese:
      return header.mese;
    case ProductGroup::kPisarenko:
      return header.pisarenko;
    case ProductGroup::kBounds:
      return header.bounds_r.has_value();
  }
  return false;
}

absl::Status CreateGroup(hid_t file, const char* path) {
  h5::Id group = h5::Group(H5Gcreate2(file, path, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!group.valid()) return absl::InternalError(absl::StrCat("cannot create group ", path));
  return group.Close();
}

absl::Status WriteRootAttributes(hid_t file, const ReconstructionHeader& header) {
  for (absl::Status status : {
           WriteFormatAttribute(file, kReconstructionFormatName, kReconstructionFormatMajor),
           h5::WriteDoubleAttribute(file, "base_frequency_hz", header.base_frequency_hz),
           h5::WriteInt64Attribute(file, "bins", static_cast<int64_t>(header.phases.size())),
           h5::WriteStringAttribute(file, "method", header.method),
           h5::WriteDoubleAttribute(file, "bias_epsilon", header.bias_epsilon),
           h5::WriteStringAttribute(file, "bias_mode", header.bias_mode),
           h5::WriteStringAttribute(file, "zeroth", header.zeroth),
           h5::WriteDoubleAttribute(file, "threshold", header.threshold),
           h5::WriteInt64Attribute(file, "order", header.order),
           h5::WriteInt64Attribute(file, "first_frame", header.first_frame),
           h5::WriteStringAttribute(file, "source", header.source),
       }) {
    if (!status.ok()) return status;
  }
  if (header.bounds_r.has_value()) {
    return h5::WriteDoubleAttribute(file, "bounds_r", *header.bounds_r);
  }
  return absl::OkStatus();
}

// /phase_rad: the phases of the bins planes, so that plots need not recompute them.
absl::Status WritePhases(hid_t file, const std::vector<double>& phases) {
  if (absl::Status status = h5::WriteDataset(file, kPhasesPath, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                                             {phases.size()}, phases.data());
      !status.ok()) {
    return status;
  }
  h5::Id dataset = h5::Dataset(H5Dopen2(file, kPhasesPath, H5P_DEFAULT));
  if (!dataset.valid()) return absl::InternalError(absl::StrCat("cannot open ", kPhasesPath));
  if (absl::Status written = h5::WriteStringAttribute(dataset.get(), "units", units::kRadians);
      !written.ok()) {
    return written;
  }
  return dataset.Close();
}

}  // namespace

int PlaneCount(ProductPlanes planes, int bins, int order) {
  switch (planes) {
    case ProductPlanes::kOne:
      return 1;
    case ProductPlanes::kBins:
      return bins;
    case ProductPlanes::kOrder:
      return order;
  }
  return 0;
}

ProductBlock BlockOf(const ProductLayout& layout, int64_t frame, int first_plane, int planes,
                     ImageGeometry geometry) {
  const hsize_t height = geometry.height, width = geometry.width;
  const hsize_t index = static_cast<hsize_t>(frame);
  if (layout.planes == ProductPlanes::kOne) return {{index, 0, 0}, {1, height, width}};
  return {{index, static_cast<hsize_t>(first_plane), 0, 0},
          {1, static_cast<hsize_t>(planes), height, width}};
}

absl::StatusOr<ReconstructionFile> ReconstructionFile::Create(const std::string& path,
                                                              const ReconstructionHeader& header) {
  h5::SilenceErrorStack();
  ReconstructionFile file;
  file.path_ = path;
  file.geometry_ = header.geometry;
  file.frames_ = header.frames;
  file.file_ = h5::File(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!file.file_.valid()) {
    return absl::PermissionDeniedError(absl::StrCat(path, ": cannot create the file"));
  }
  const hid_t id = file.file_.get();
  const auto failed = [&](const absl::Status& status) {
    return WithContext(path, status);
  };
  if (absl::Status status = WriteRootAttributes(id, header); !status.ok()) return failed(status);
  if (header.pisarenko) {
    if (absl::Status status = CreateGroup(id, "/pisarenko"); !status.ok()) return failed(status);
  }
  if (header.bounds_r.has_value()) {
    if (absl::Status status = CreateGroup(id, "/bounds"); !status.ok()) return failed(status);
  }
  if (header.mese || header.bounds_r.has_value()) {
    if (absl::Status status = WritePhases(id, header.phases); !status.ok()) return failed(status);
  }

  const float nan = std::numeric_limits<float>::quiet_NaN();
  const uint8_t zero = 0;
  for (const ProductLayout& spec : kProductLayouts) {
    if (!Written(spec.group, header)) continue;
    const int planes =
        PlaneCount(spec.planes, static_cast<int>(header.phases.size()), header.order);
    // Every frame's planes, one image plane per chunk.
    std::vector<hsize_t> dims = BlockOf(spec, 0, 0, planes, header.geometry).count;
    dims[0] = static_cast<hsize_t>(header.frames);
    const std::vector<hsize_t> chunk = BlockOf(spec, 0, 0, 1, header.geometry).count;
    const bool is_flags = spec.product == Product::kFlags;
    absl::StatusOr<h5::Id> dataset =
        h5::CreateDataset(id, spec.path, is_flags ? H5T_STD_U8LE : H5T_IEEE_F32LE,
                          {.dims = dims,
                           .chunk = chunk,
                           .fill_type = is_flags ? H5T_NATIVE_UINT8 : H5T_NATIVE_FLOAT,
                           .fill = is_flags ? static_cast<const void*>(&zero) : &nan});
    if (!dataset.ok()) return failed(dataset.status());
    if (absl::Status written = h5::WriteStringAttribute(dataset->get(), "units", spec.units);
        !written.ok()) {
      return failed(written);
    }
    file.datasets_[Index(spec.product)] = *std::move(dataset);
    file.planes_[Index(spec.product)] = planes;
  }
  return file;
}

absl::Status ReconstructionFile::WritePlanes(Product product, int64_t frame, int first_plane,
                                             int64_t values, hid_t memory_type, const void* data) {
  const ProductLayout& spec = kProductLayouts[Index(product)];
  const int64_t pixels = geometry_.pixel_count();
  const int planes = planes_[Index(product)];
  const int64_t count = pixels > 0 ? values / pixels : 0;
  if (!has(product) || frame < 0 || frame >= frames_ || count * pixels != values || count < 1 ||
      first_plane < 0 || first_plane + count > planes) {
    return absl::InternalError(absl::StrCat(path_, ": ", spec.path, ": bad write of ", values,
                                            " values at frame ", frame, ", plane ", first_plane));
  }
  const ProductBlock block = BlockOf(spec, frame, first_plane, static_cast<int>(count), geometry_);
  if (!h5::WriteBlock(datasets_[Index(product)].get(), block.start, block.count, memory_type, data)
           .ok()) {
    return absl::UnavailableError(
        absl::StrCat(path_, ": ", spec.path, ": writing frame ", frame, " failed (disk full?)"));
  }
  return absl::OkStatus();
}

absl::Status ReconstructionFile::Write(Product product, int64_t frame, int first_plane,
                                       std::span<const float> planes) {
  if (product == Product::kFlags) {
    return absl::InternalError(absl::StrCat(path_, ": /flags is written with WriteFlags"));
  }
  return WritePlanes(product, frame, first_plane, static_cast<int64_t>(planes.size()),
                     H5T_NATIVE_FLOAT, planes.data());
}

absl::Status ReconstructionFile::WriteFlags(int64_t frame, std::span<const uint8_t> flags) {
  return WritePlanes(Product::kFlags, frame, 0, static_cast<int64_t>(flags.size()),
                     H5T_NATIVE_UINT8, flags.data());
}

absl::Status ReconstructionFile::Close() {
  absl::Status result;
  for (h5::Id& dataset : datasets_) result.Update(dataset.Close());
  result.Update(file_.Close());
  if (!result.ok()) {
    return absl::UnavailableError(
        absl::StrCat(path_, ": closing the file failed (disk full?): ", result.message()));
  }
  return absl::OkStatus();
}

}  // namespace transient

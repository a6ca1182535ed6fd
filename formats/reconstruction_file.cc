// Dataset layout and frame-by-frame hyperslab writes of `transient-reconstruction 1` files.
#include "transient/formats/reconstruction_file.h"

#include <limits>

#include "absl/strings/str_cat.h"
#include "transient/formats/format_tag.h"

namespace transient {
namespace {

bool Wanted(Product product, const ReconstructionHeader& header) {
  switch (product) {
    case Product::kRange:
    case Product::kZerothMoment:
    case Product::kFlags:
      return true;
    case Product::kDensity:
    case Product::kCumulative:
      return header.mese;
    case Product::kPisarenkoPhase:
    case Product::kPisarenkoWeight:
    case Product::kPisarenkoUniform:
    case Product::kPisarenkoRange:
    case Product::kPisarenkoDirect:
    case Product::kPisarenkoIndirect:
      return header.pisarenko;
    case Product::kBoundsLower:
    case Product::kBoundsUpper:
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
           h5::WriteStringAttribute(
               file, "format",
               FormatTagString(kReconstructionFormatName, kReconstructionFormatMajor)),
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
  const hsize_t dims[1] = {phases.size()};
  h5::Id space = h5::Dataspace(H5Screate_simple(1, dims, nullptr));
  h5::Id dataset = h5::Dataset(H5Dcreate2(file, "/phase_rad", H5T_IEEE_F64LE, space.get(),
                                          H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!dataset.valid() || H5Dwrite(dataset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                                   phases.data()) < 0) {
    return absl::InternalError("cannot write /phase_rad");
  }
  if (absl::Status written = h5::WriteStringAttribute(dataset.get(), "units", units::kRadians);
      !written.ok()) {
    return written;
  }
  return dataset.Close();
}

}  // namespace

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
    return absl::Status(status.code(), absl::StrCat(path, ": ", status.message()));
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

  const hsize_t frames = header.frames;
  const hsize_t height = header.geometry.height, width = header.geometry.width;
  for (const ProductLayout& spec : kProductLayouts) {
    if (!Wanted(spec.product, header)) continue;
    const int planes = spec.planes == ProductPlanes::kOne    ? 1
                       : spec.planes == ProductPlanes::kBins ? static_cast<int>(header.phases.size())
                                                      : header.order;
    const bool stacked = spec.planes != ProductPlanes::kOne;
    const std::vector<hsize_t> dims =
        stacked ? std::vector<hsize_t>{frames, static_cast<hsize_t>(planes), height, width}
                : std::vector<hsize_t>{frames, height, width};
    const std::vector<hsize_t> chunk = stacked ? std::vector<hsize_t>{1, 1, height, width}
                                               : std::vector<hsize_t>{1, height, width};
    const bool is_flags = spec.product == Product::kFlags;
    const hid_t file_type = is_flags ? H5T_STD_U8LE : H5T_IEEE_F32LE;

    h5::Id space =
        h5::Dataspace(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
    h5::Id creation = h5::PropertyList(H5Pcreate(H5P_DATASET_CREATE));
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const uint8_t zero = 0;
    if (H5Pset_chunk(creation.get(), static_cast<int>(chunk.size()), chunk.data()) < 0 ||
        H5Pset_fill_value(creation.get(), is_flags ? H5T_NATIVE_UINT8 : H5T_NATIVE_FLOAT,
                          is_flags ? static_cast<const void*>(&zero) : &nan) < 0) {
      return absl::InternalError(absl::StrCat(path, ": cannot set up chunks of ",
                                              h5::DimensionsToString(chunk), " for ", spec.path));
    }
    h5::Id dataset = h5::Dataset(H5Dcreate2(id, spec.path, file_type, space.get(), H5P_DEFAULT,
                                            creation.get(), H5P_DEFAULT));
    if (!dataset.valid()) {
      return absl::InternalError(absl::StrCat(path, ": cannot create dataset ", spec.path));
    }
    if (spec.units != nullptr) {
      if (absl::Status written = h5::WriteStringAttribute(dataset.get(), "units", spec.units);
          !written.ok()) {
        return failed(written);
      }
    }
    file.datasets_[Index(spec.product)] = std::move(dataset);
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
  const hsize_t height = geometry_.height, width = geometry_.width;
  const bool stacked = spec.planes != ProductPlanes::kOne;
  const std::vector<hsize_t> start =
      stacked ? std::vector<hsize_t>{static_cast<hsize_t>(frame), static_cast<hsize_t>(first_plane),
                                     0, 0}
              : std::vector<hsize_t>{static_cast<hsize_t>(frame), 0, 0};
  const std::vector<hsize_t> extent =
      stacked ? std::vector<hsize_t>{1, static_cast<hsize_t>(count), height, width}
              : std::vector<hsize_t>{1, height, width};
  const hid_t dataset = datasets_[Index(product)].get();
  h5::Id memory =
      h5::Dataspace(H5Screate_simple(static_cast<int>(extent.size()), extent.data(), nullptr));
  h5::Id selection = h5::Dataspace(H5Dget_space(dataset));
  if (H5Sselect_hyperslab(selection.get(), H5S_SELECT_SET, start.data(), nullptr, extent.data(),
                          nullptr) < 0 ||
      H5Dwrite(dataset, memory_type, memory.get(), selection.get(), H5P_DEFAULT, data) < 0) {
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

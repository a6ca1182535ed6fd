// Extendible, frame-chunked datasets of `transient-moments 1` files.
#include "transient/formats/moment_file_writer.h"

#include <vector>

#include "absl/strings/str_cat.h"
#include "transient/formats/format_tag.h"
#include "transient/formats/moment_file.h"

namespace transient {
namespace {

// An extendible dataset [0, dims...] chunked as [1, dims...].
absl::StatusOr<h5::Id> CreateExtendible(hid_t parent, const char* name, hid_t type,
                                        std::vector<hsize_t> frame_dims) {
  std::vector<hsize_t> dims{0}, max_dims{H5S_UNLIMITED}, chunk{1};
  for (hsize_t d : frame_dims) {
    dims.push_back(d);
    max_dims.push_back(d);
    chunk.push_back(d);
  }
  if (frame_dims.empty()) chunk[0] = 1024;  // 1-D per-frame values: small chunks of many frames
  h5::Id space = h5::Dataspace(H5Screate_simple(static_cast<int>(dims.size()), dims.data(),
                                                max_dims.data()));
  h5::Id creation = h5::PropertyList(H5Pcreate(H5P_DATASET_CREATE));
  if (!space.valid() || !creation.valid() ||
      H5Pset_chunk(creation.get(), static_cast<int>(chunk.size()), chunk.data()) < 0) {
    return absl::InternalError(absl::StrCat("cannot set up dataset ", name));
  }
  h5::Id dataset = h5::Dataset(H5Dcreate2(parent, name, type, space.get(), H5P_DEFAULT,
                                          creation.get(), H5P_DEFAULT));
  if (!dataset.valid()) return absl::InternalError(absl::StrCat("cannot create dataset ", name));
  return dataset;
}

// Extends `dataset` to `frames` along its first dimension and writes `data` as frame
// `frames - 1`.
absl::Status AppendFrame(hid_t dataset, int64_t frames, hid_t memory_type, const void* data,
                         const char* name) {
  h5::Id space = h5::Dataspace(H5Dget_space(dataset));
  std::vector<hsize_t> dims = h5::Dimensions(space.get());
  dims[0] = static_cast<hsize_t>(frames);
  if (H5Dset_extent(dataset, dims.data()) < 0) {
    return absl::InternalError(absl::StrCat("cannot extend ", name));
  }
  h5::Id file_space = h5::Dataspace(H5Dget_space(dataset));
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = dims[0] - 1;
  count[0] = 1;
  h5::Id memory_space =
      h5::Dataspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr));
  if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(),
                          nullptr) < 0 ||
      H5Dwrite(dataset, memory_type, memory_space.get(), file_space.get(), H5P_DEFAULT, data) <
          0) {
    return absl::InternalError(absl::StrCat("cannot write frame ", frames - 1, " of ", name));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<MomentFileWriter> MomentFileWriter::Create(const std::string& path,
                                                          const MomentFileHeader& header) {
  h5::SilenceErrorStack();
  MomentFileWriter writer;
  writer.path_ = path;
  writer.header_ = header;
  writer.file_ = h5::File(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!writer.file_.valid()) {
    return absl::PermissionDeniedError(absl::StrCat(path, ": cannot create the file"));
  }
  const hid_t file = writer.file_.get();
  h5::Id group = h5::Group(H5Gcreate2(file, "/moments", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!group.valid()) return absl::InternalError(absl::StrCat(path, ": cannot create /moments"));
  for (absl::Status status : {
           h5::WriteStringAttribute(file, "format",
                                    FormatTagString(kMomentFormatName, kMomentFormatMajor)),
           h5::WriteDoubleAttribute(group.get(), "base_frequency_hz", header.base_frequency_hz),
           h5::WriteStringAttribute(group.get(), "zeroth",
                                    header.zeroth == ZerothScheme::kEstimated ? "estimated"
                                                                              : "measured"),
           h5::WriteStringAttribute(group.get(), "source", header.source),
           h5::WriteStringAttribute(group.get(), "calibration", header.calibration),
           h5::WriteDoubleAttribute(group.get(), "smoothing_sigma_px", header.smoothing_sigma_px),
       }) {
    if (!status.ok()) return status;
  }
  const auto planes = static_cast<hsize_t>(header.order + 1);
  const auto height = static_cast<hsize_t>(header.geometry.height);
  const auto width = static_cast<hsize_t>(header.geometry.width);
  struct Spec {
    h5::Id* id;
    const char* name;
    hid_t type;
    std::vector<hsize_t> dims;
  };
  for (Spec spec : {Spec{&writer.real_, "real", H5T_IEEE_F32LE, {planes, height, width}},
                    Spec{&writer.imag_, "imag", H5T_IEEE_F32LE, {planes, height, width}},
                    Spec{&writer.valid_, "valid", H5T_STD_U8LE, {height, width}},
                    Spec{&writer.flags_, "flags", H5T_STD_U8LE, {height, width}},
                    Spec{&writer.timestamp_, "timestamp_s", H5T_IEEE_F64LE, {}}}) {
    absl::StatusOr<h5::Id> dataset = CreateExtendible(group.get(), spec.name, spec.type, spec.dims);
    if (!dataset.ok()) {
      return absl::Status(dataset.status().code(), absl::StrCat(path, ": ", dataset.status().message()));
    }
    *spec.id = *std::move(dataset);
  }
  return writer;
}

absl::Status MomentFileWriter::Append(const MomentImage& moments, double timestamp_s) {
  if (!(moments.geometry == header_.geometry) || moments.order != header_.order) {
    return absl::InvalidArgumentError(absl::StrCat(
        path_, ": frame of ", moments.geometry.width, "x", moments.geometry.height, ", m = ",
        moments.order, " does not fit the file's ", header_.geometry.width, "x",
        header_.geometry.height, ", m = ", header_.order));
  }
  const size_t pixels = static_cast<size_t>(moments.geometry.pixel_count());
  const std::vector<uint8_t> all_valid(moments.valid.empty() ? pixels : 0, 1);
  const std::vector<uint8_t> no_flags(moments.flags.empty() ? pixels : 0, 0);
  const uint8_t* valid = moments.valid.empty() ? all_valid.data() : moments.valid.data();
  const uint8_t* flags = moments.flags.empty() ? no_flags.data() : moments.flags.data();
  const int64_t frames = frames_ + 1;
  for (absl::Status status : {
           AppendFrame(real_.get(), frames, H5T_NATIVE_FLOAT, moments.real.data(), "real"),
           AppendFrame(imag_.get(), frames, H5T_NATIVE_FLOAT, moments.imag.data(), "imag"),
           AppendFrame(valid_.get(), frames, H5T_NATIVE_UINT8, valid, "valid"),
           AppendFrame(flags_.get(), frames, H5T_NATIVE_UINT8, flags, "flags"),
           AppendFrame(timestamp_.get(), frames, H5T_NATIVE_DOUBLE, &timestamp_s, "timestamp_s"),
       }) {
    if (!status.ok()) return absl::Status(status.code(), absl::StrCat(path_, ": ", status.message()));
  }
  frames_ = frames;
  return absl::OkStatus();
}

absl::Status MomentFileWriter::Close() {
  for (h5::Id* id : {&real_, &imag_, &valid_, &flags_, &timestamp_}) {
    if (absl::Status status = id->Close(); !status.ok()) return status;
  }
  if (absl::Status status = file_.Close(); !status.ok()) {
    return absl::DataLossError(absl::StrCat(path_, ": cannot finish the file: ", status.message()));
  }
  return absl::OkStatus();
}

}  // namespace transient

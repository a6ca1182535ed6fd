// Extendible, frame-chunked datasets of `transient-moments 1` files.
#include "transient/formats/moment_file_writer.h"

#include <tuple>
#include <vector>

#include "absl/strings/str_cat.h"
#include "transient/formats/format_tag.h"
#include "transient/formats/moment_file.h"

namespace transient {
namespace {

// An extendible dataset [0, frame_dims...] chunked one frame per chunk, [1, frame_dims...]; a
// one-dimensional per-frame value is chunked in runs of many frames.
absl::StatusOr<h5::Id> CreateExtendible(hid_t parent, const char* name, hid_t type,
                                        const std::vector<hsize_t>& frame_dims) {
  constexpr hsize_t kValuesPerChunk = 1024;
  h5::DatasetLayout layout{.dims = {0}, .max_dims = {H5S_UNLIMITED}, .chunk = {1}};
  for (hsize_t d : frame_dims) {
    layout.dims.push_back(d);
    layout.max_dims.push_back(d);
    layout.chunk.push_back(d);
  }
  if (frame_dims.empty()) layout.chunk[0] = kValuesPerChunk;
  return h5::CreateDataset(parent, name, type, layout);
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
           WriteFormatAttribute(file, kMomentFormatName, kMomentFormatMajor),
           h5::WriteDoubleAttribute(group.get(), "base_frequency_hz", header.base_frequency_hz),
           h5::WriteStringAttribute(
               group.get(), "zeroth",
               header.zeroth == ZerothScheme::kEstimated ? "estimated" : "measured"),
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
      return absl::Status(dataset.status().code(),
                          absl::StrCat(path, ": ", dataset.status().message()));
    }
    *spec.id = *std::move(dataset);
  }
  return writer;
}

absl::Status MomentFileWriter::Append(const MomentImage& moments, double timestamp_s) {
  if (!(moments.geometry == header_.geometry) || moments.order != header_.order) {
    return absl::InvalidArgumentError(
        absl::StrCat(path_, ": frame of ", moments.geometry.width, "x", moments.geometry.height,
                     ", m = ", moments.order, " does not fit the file's ", header_.geometry.width,
                     "x", header_.geometry.height, ", m = ", header_.order));
  }
  const size_t pixels = static_cast<size_t>(moments.geometry.pixel_count());
  const std::vector<uint8_t> all_valid(moments.valid.empty() ? pixels : 0, 1);
  const std::vector<uint8_t> no_flags(moments.flags.empty() ? pixels : 0, 0);
  const uint8_t* valid = moments.valid.empty() ? all_valid.data() : moments.valid.data();
  const uint8_t* flags = moments.flags.empty() ? no_flags.data() : moments.flags.data();
  const hsize_t index = static_cast<hsize_t>(frames_);
  for (auto [dataset, memory_type, data, name] :
       {std::tuple{real_.get(), H5T_NATIVE_FLOAT, static_cast<const void*>(moments.real.data()),
                   "real"},
        std::tuple{imag_.get(), H5T_NATIVE_FLOAT, static_cast<const void*>(moments.imag.data()),
                   "imag"},
        std::tuple{valid_.get(), H5T_NATIVE_UINT8, static_cast<const void*>(valid), "valid"},
        std::tuple{flags_.get(), H5T_NATIVE_UINT8, static_cast<const void*>(flags), "flags"},
        std::tuple{timestamp_.get(), H5T_NATIVE_DOUBLE, static_cast<const void*>(&timestamp_s),
                   "timestamp_s"}}) {
    if (!h5::AppendAlongFirst(dataset, index, memory_type, data).ok()) {
      return absl::InternalError(
          absl::StrCat(path_, ": cannot write frame ", frames_, " of ", name));
    }
  }
  ++frames_;
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

// Layout checks and hyperslab reads of `transient-moments 1` files.
#include "transient/formats/moment_file.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <tuple>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "transient/formats/format_tag.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

constexpr char kMomentsGroup[] = "/moments";
constexpr char kRealPath[] = "/moments/real";
constexpr char kImagPath[] = "/moments/imag";
constexpr char kValidPath[] = "/moments/valid";
constexpr char kFlagsPath[] = "/moments/flags";
constexpr char kZerothAttribute[] = "zeroth";
constexpr char kBaseFrequencyAttribute[] = "base_frequency_hz";
constexpr char kFormatAttribute[] = "format";

using h5::CheckFiltersAvailable;
using h5::OpenObject;

// Opens /moments/real or /moments/imag: float32 or float64, 4 dimensions.
absl::StatusOr<h5::Id> OpenMomentDataset(hid_t file, const std::string& file_path,
                                         const char* object_path, std::vector<hsize_t>* dims) {
  absl::StatusOr<h5::Id> dataset =
      OpenObject(file, file_path, object_path, H5I_DATASET,
                 "dataset (float32 or float64, [frames, m+1, height, width])");
  if (!dataset.ok()) return dataset.status();
  const std::string where = absl::StrCat(file_path, ": ", object_path);
  h5::Id type = h5::Datatype(H5Dget_type(dataset->get()));
  const size_t size = H5Tget_size(type.get());
  if (H5Tget_class(type.get()) != H5T_FLOAT || (size != 4 && size != 8)) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": expected float32 or float64, found ", h5::DescribeType(type.get())));
  }
  h5::Id space = h5::Dataspace(H5Dget_space(dataset->get()));
  *dims = h5::Dimensions(space.get());
  if (dims->size() != 4) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ": expected 4 dimensions [frames, m+1, height, width], found ", dims->size()));
  }
  if (absl::Status status = CheckFiltersAvailable(dataset->get(), where); !status.ok()) {
    return status;
  }
  return dataset;
}

// Opens an optional one-byte per-pixel dataset ([frames, height, width]: /moments/valid,
// /moments/flags) and checks its type, shape and filters.
absl::StatusOr<h5::Id> OpenPixelPlanes(hid_t id, const std::string& path, const char* dataset_path,
                                       const std::vector<hsize_t>& expected) {
  absl::StatusOr<h5::Id> dataset =
      OpenObject(id, path, dataset_path, H5I_DATASET, "dataset (uint8, [frames, height, width])");
  if (!dataset.ok()) return dataset.status();
  const std::string where = absl::StrCat(path, ": ", dataset_path);
  h5::Id type = h5::Datatype(H5Dget_type(dataset->get()));
  const H5T_class_t type_class = H5Tget_class(type.get());
  // h5py stores numpy booleans as a one-byte enum; accept them beside (u)int8.
  if ((type_class != H5T_INTEGER && type_class != H5T_ENUM) || H5Tget_size(type.get()) != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": expected uint8, found ", h5::DescribeType(type.get())));
  }
  h5::Id space = h5::Dataspace(H5Dget_space(dataset->get()));
  const std::vector<hsize_t> dims = h5::Dimensions(space.get());
  if (dims != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ": expected shape [frames, height, width] = ", h5::DimensionsToString(expected),
        ", found ", h5::DimensionsToString(dims)));
  }
  if (absl::Status status = CheckFiltersAvailable(dataset->get(), where); !status.ok()) {
    return status;
  }
  return dataset;
}

}  // namespace

absl::StatusOr<MomentFile> MomentFile::Open(const std::string& path) {
  h5::SilenceErrorStack();
  if (absl::Status readable = h5::CheckReadableFile(path, "an HDF5 moment file"); !readable.ok()) {
    return readable;
  }

  MomentFile file;
  file.path_ = path;
  file.file_ = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!file.file_.valid()) {
    return absl::DataLossError(
        absl::StrCat(path, ": HDF5 cannot open the file (corrupt, truncated or locked)"));
  }
  const hid_t id = file.file_.get();

  absl::StatusOr<std::string> format =
      h5::ReadStringAttribute(id, kFormatAttribute, absl::StrCat(path, ": /"));
  if (!format.ok()) return format.status();
  if (absl::Status tag = CheckFormatTag(*format, kMomentFormatName, kMomentFormatMajor);
      !tag.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": /: attribute ", kFormatAttribute, ": ", tag.message()));
  }

  absl::StatusOr<h5::Id> group =
      OpenObject(id, path, kMomentsGroup, H5I_GROUP, "group (with datasets real and imag)");
  if (!group.ok()) return group.status();

  std::vector<hsize_t> real_dims, imag_dims;
  absl::StatusOr<h5::Id> real = OpenMomentDataset(id, path, kRealPath, &real_dims);
  if (!real.ok()) return real.status();
  absl::StatusOr<h5::Id> imag = OpenMomentDataset(id, path, kImagPath, &imag_dims);
  if (!imag.ok()) return imag.status();
  if (imag_dims != real_dims) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": ", kImagPath, ": expected the shape of ", kRealPath, " ",
        h5::DimensionsToString(real_dims), ", found ", h5::DimensionsToString(imag_dims)));
  }
  file.real_ = *std::move(real);
  file.imag_ = *std::move(imag);

  const std::string real_where = absl::StrCat(path, ": ", kRealPath);
  const hsize_t frames = real_dims[0], moments = real_dims[1];
  const hsize_t height = real_dims[2], width = real_dims[3];
  if (frames == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(real_where, ": expected at least 1 frame, found 0"));
  }
  if (moments < 2 || moments > static_cast<hsize_t>(kMaxMoments)) {
    return absl::InvalidArgumentError(absl::StrCat(real_where, ": expected m+1 = 2..", kMaxMoments,
                                                   " moments (m = 1..", kMaxOrder,
                                                   ") in dimension 2, found ", moments));
  }
  if (height == 0 || width == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        real_where, ": expected a non-empty image, found height ", height, " and width ", width));
  }
  // One image plane is one HDF5 chunk of the output, and HDF5 caps chunks below 4 GiB.
  if (height > kMaxImagePixels || width > kMaxImagePixels || height * width > kMaxImagePixels) {
    return absl::InvalidArgumentError(absl::StrCat(real_where, ": expected at most ",
                                                   kMaxImagePixels, " pixels per image, found ",
                                                   height, " x ", width));
  }
  file.frames_ = static_cast<int64_t>(frames);
  file.order_ = static_cast<int>(moments) - 1;
  file.geometry_ = {.width = static_cast<int>(width), .height = static_cast<int>(height)};

  absl::StatusOr<double> frequency = h5::ReadNumericAttribute(
      group->get(), kBaseFrequencyAttribute, absl::StrCat(path, ": ", kMomentsGroup));
  if (!frequency.ok()) return frequency.status();
  if (!std::isfinite(*frequency) || *frequency <= 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", kMomentsGroup, ": attribute ", kBaseFrequencyAttribute,
                     ": expected a finite value > 0, found ", *frequency));
  }
  file.base_frequency_hz_ = *frequency;

  for (auto [dataset_path, target] : {std::pair{kValidPath, &file.valid_},
                                      std::pair{kFlagsPath, &file.flags_}}) {
    if (!h5::LinkExists(id, dataset_path)) continue;
    absl::StatusOr<h5::Id> plane = OpenPixelPlanes(id, path, dataset_path, {frames, height, width});
    if (!plane.ok()) return plane.status();
    *target = *std::move(plane);
  }
  if (H5Aexists(group->get(), kZerothAttribute) > 0) {
    absl::StatusOr<std::string> zeroth = h5::ReadStringAttribute(
        group->get(), kZerothAttribute, absl::StrCat(path, ": ", kMomentsGroup));
    if (!zeroth.ok()) return zeroth.status();
    if (*zeroth == "measured") {
      file.zeroth_hint_ = ZerothMoment::kMeasured;
    } else if (*zeroth == "estimated") {
      file.zeroth_hint_ = ZerothMoment::kEstimate;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(path, ": ", kMomentsGroup, ": attribute ",
                                                     kZerothAttribute,
                                                     ": expected 'measured' or 'estimated', found '",
                                                     *zeroth, "'"));
    }
  }
  return file;
}

absl::Status MomentFile::ReadFrame(int64_t frame, MomentImage* image) const {
  if (frame < 0 || frame >= frames_) {
    return absl::OutOfRangeError(
        absl::StrCat(path_, ": frame ", frame, " is outside 0..", frames_ - 1));
  }
  const int64_t pixels = geometry_.pixel_count();
  image->geometry = geometry_;
  image->order = order_;
  image->real.resize((order_ + 1) * pixels);
  image->imag.resize((order_ + 1) * pixels);

  const auto read_failed = [&](const char* object) {
    return absl::DataLossError(
        absl::StrCat(path_, ": ", object, ": cannot read frame ", frame, " (corrupt file?)"));
  };
  const hsize_t height = geometry_.height, width = geometry_.width;
  {
    const hsize_t start[4] = {static_cast<hsize_t>(frame), 0, 0, 0};
    const hsize_t count[4] = {1, static_cast<hsize_t>(order_ + 1), height, width};
    h5::Id memory = h5::Dataspace(H5Screate_simple(4, count, nullptr));
    for (auto [dataset, buffer, object] :
         {std::tuple{real_.get(), image->real.data(), kRealPath},
          std::tuple{imag_.get(), image->imag.data(), kImagPath}}) {
      h5::Id selection = h5::Dataspace(H5Dget_space(dataset));
      if (H5Sselect_hyperslab(selection.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) <
              0 ||
          H5Dread(dataset, H5T_NATIVE_FLOAT, memory.get(), selection.get(), H5P_DEFAULT, buffer) <
              0) {
        return read_failed(object);
      }
    }
  }
  const hsize_t start[3] = {static_cast<hsize_t>(frame), 0, 0};
  const hsize_t count[3] = {1, height, width};
  h5::Id memory = h5::Dataspace(H5Screate_simple(3, count, nullptr));
  for (auto [dataset, buffer, object] : {std::tuple{&valid_, &image->valid, kValidPath},
                                         std::tuple{&flags_, &image->flags, kFlagsPath}}) {
    if (!dataset->valid()) {
      buffer->clear();
      continue;
    }
    buffer->resize(pixels);
    h5::Id selection = h5::Dataspace(H5Dget_space(dataset->get()));
    h5::Id file_type = h5::Datatype(H5Dget_type(dataset->get()));
    // The native form of the stored one-byte type: HDF5 converts neither enums to integers nor
    // back, and both are one byte whose zero means "invalid" (valid) or "nothing" (flags).
    h5::Id memory_type = h5::Datatype(H5Tget_native_type(file_type.get(), H5T_DIR_ASCEND));
    if (H5Sselect_hyperslab(selection.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
        H5Dread(dataset->get(), memory_type.get(), memory.get(), selection.get(), H5P_DEFAULT,
                buffer->data()) < 0) {
      return read_failed(object);
    }
  }
  return absl::OkStatus();
}

}  // namespace transient

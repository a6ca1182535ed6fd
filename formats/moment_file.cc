// Layout checks and hyperslab reads of `transient-moments 1` files.
#include "transient/formats/moment_file.h"

#include <tuple>
#include <utility>
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

constexpr char kMomentShape[] = "[frames, m+1, height, width]";
constexpr char kPlaneShape[] = "[frames, height, width]";

using h5::Where;

}  // namespace

absl::StatusOr<MomentFile> MomentFile::Open(const std::string& path) {
  absl::StatusOr<h5::Id> opened = h5::OpenFileForReading(path, "an HDF5 moment file");
  if (!opened.ok()) return opened.status();
  MomentFile file;
  file.path_ = path;
  file.file_ = *std::move(opened);
  const hid_t id = file.file_.get();

  if (absl::Status status =
          ReadFormatAttribute(id, Where(path, "/"), kMomentFormatName, kMomentFormatMajor);
      !status.ok()) {
    return status;
  }
  absl::StatusOr<h5::Id> group =
      h5::OpenObject(id, path, kMomentsGroup, H5I_GROUP, "group (with datasets real and imag)");
  if (!group.ok()) return group.status();

  std::vector<hsize_t> real_dims, imag_dims;
  absl::StatusOr<h5::Id> real =
      h5::OpenDataset(id, path, kRealPath, h5::kAnyFloat, 4, kMomentShape, &real_dims);
  if (!real.ok()) return real.status();
  absl::StatusOr<h5::Id> imag =
      h5::OpenDataset(id, path, kImagPath, h5::kAnyFloat, 4, kMomentShape, &imag_dims);
  if (!imag.ok()) return imag.status();
  if (imag_dims != real_dims) {
    return absl::InvalidArgumentError(absl::StrCat(
        Where(path, kImagPath), ": expected the shape of ", kRealPath, " ",
        h5::DimensionsToString(real_dims), ", found ", h5::DimensionsToString(imag_dims)));
  }
  file.real_ = *std::move(real);
  file.imag_ = *std::move(imag);

  const std::string real_where = Where(path, kRealPath);
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
  if (absl::Status status = h5::CheckImageSize(real_where, height, width); !status.ok()) {
    return status;
  }
  file.frames_ = static_cast<int64_t>(frames);
  file.order_ = static_cast<int>(moments) - 1;
  file.geometry_ = {.width = static_cast<int>(width), .height = static_cast<int>(height)};

  const std::string group_where = Where(path, kMomentsGroup);
  absl::StatusOr<double> frequency = h5::ReadFiniteAttribute(group->get(), kBaseFrequencyAttribute,
                                                             group_where, h5::Sign::kPositive);
  if (!frequency.ok()) return frequency.status();
  file.base_frequency_hz_ = *frequency;

  // Optional one-byte planes; h5py's bool enum is accepted beside (u)int8.
  for (auto [dataset_path, target] :
       {std::pair{kValidPath, &file.valid_}, std::pair{kFlagsPath, &file.flags_}}) {
    if (!h5::LinkExists(id, dataset_path)) continue;
    std::vector<hsize_t> dims;
    absl::StatusOr<h5::Id> plane =
        h5::OpenDataset(id, path, dataset_path, h5::kByte, 3, kPlaneShape, &dims);
    if (!plane.ok()) return plane.status();
    if (absl::Status status =
            h5::CheckShape(Where(path, dataset_path), dims, {frames, height, width}, kPlaneShape);
        !status.ok()) {
      return status;
    }
    *target = *std::move(plane);
  }
  if (H5Aexists(group->get(), kZerothAttribute) > 0) {
    absl::StatusOr<std::string> zeroth =
        h5::ReadStringAttribute(group->get(), kZerothAttribute, group_where);
    if (!zeroth.ok()) return zeroth.status();
    if (*zeroth == "measured") {
      file.zeroth_hint_ = ZerothMoment::kMeasured;
    } else if (*zeroth == "estimated") {
      file.zeroth_hint_ = ZerothMoment::kEstimate;
    } else {
      return absl::InvalidArgumentError(
          absl::StrCat(group_where, ": attribute ", kZerothAttribute,
                       ": expected 'measured' or 'estimated', found '", *zeroth, "'"));
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
  const hsize_t index = static_cast<hsize_t>(frame);
  const hsize_t planes = static_cast<hsize_t>(order_ + 1);
  const hsize_t height = geometry_.height, width = geometry_.width;
  for (auto [dataset, buffer, object] : {std::tuple{real_.get(), image->real.data(), kRealPath},
                                         std::tuple{imag_.get(), image->imag.data(), kImagPath}}) {
    if (!h5::ReadBlock(dataset, {index, 0, 0, 0}, {1, planes, height, width}, H5T_NATIVE_FLOAT,
                       buffer)
             .ok()) {
      return read_failed(object);
    }
  }
  for (auto [dataset, buffer, object] : {std::tuple{&valid_, &image->valid, kValidPath},
                                         std::tuple{&flags_, &image->flags, kFlagsPath}}) {
    if (!dataset->valid()) {
      buffer->clear();
      continue;
    }
    buffer->resize(pixels);
    h5::Id file_type = h5::Datatype(H5Dget_type(dataset->get()));
    // The native form of the stored one-byte type: HDF5 converts neither enums to integers nor
    // back, and both are one byte whose zero means "invalid" (valid) or "nothing" (flags).
    h5::Id memory_type = h5::Datatype(H5Tget_native_type(file_type.get(), H5T_DIR_ASCEND));
    if (!h5::ReadBlock(dataset->get(), {index, 0, 0}, {1, height, width}, memory_type.get(),
                       buffer->data())
             .ok()) {
      return read_failed(object);
    }
  }
  return absl::OkStatus();
}

}  // namespace transient

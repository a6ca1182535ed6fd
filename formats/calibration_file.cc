// Calibration files and the calibration group a capture embeds: layout checks, the group's
// writer and reader, the atomic file write and the validated file read.
#include "transient/formats/calibration_file.h"

#include <cstdint>
#include <vector>

#include "absl/strings/str_cat.h"
#include "calibration_group.h"
#include "schedule_attributes.h"
#include "transient/formats/format_tag.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

using h5::Where;

// Far more than any calibration averages; bounds a corrupt value.
constexpr int64_t kMaxTakesAveraged = int64_t{1} << 40;

}  // namespace

absl::Status CheckCalibrationTable(const CalibrationTable& table) {
  const int64_t pixels = table.geometry.pixel_count();
  if (table.geometry.width < 1 || table.geometry.height < 1 || pixels > h5::kMaxImagePixels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration geometry = ", table.geometry.width, "x", table.geometry.height,
        ". Violated constraint: 1 <= width, height and width*height <= ", h5::kMaxImagePixels));
  }
  if (table.order < 1 || table.order > kMaxOrder) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration order = ", table.order, ". Violated constraint: 1 <= order <= ", kMaxOrder));
  }
  if (table.schedule.order != table.order ||
      table.schedule.base_frequency_hz != table.base_frequency_hz) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration order = ", table.order, ", base_frequency_hz = ", table.base_frequency_hz,
        ", schedule order = ", table.schedule.order,
        ", schedule base_frequency_hz = ", table.schedule.base_frequency_hz,
        ". Violated constraint: the table's order and "
        "frequency are its schedule's"));
  }
  if (absl::Status status = table.schedule.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("calibration schedule: ", status.message()));
  }
  const size_t planes = static_cast<size_t>((table.order + 1) * pixels);
  if (table.real.size() != planes || table.imag.size() != planes ||
      table.valid.size() != static_cast<size_t>(pixels)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration sizes real = ", table.real.size(), ", imag = ", table.imag.size(),
        ", valid = ", table.valid.size(), ". Violated constraint: real and imag hold (m+1)*H*W = ",
        planes, " values, valid H*W = ", pixels));
  }
  if (table.takes_averaged < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("calibration takes_averaged = ", table.takes_averaged,
                     ". Violated constraint: takes_averaged >= 0"));
  }
  return absl::OkStatus();
}

absl::Status WriteCalibrationGroup(hid_t group, const CalibrationTable& table) {
  if (absl::Status status = CheckCalibrationTable(table); !status.ok()) return status;
  // The table's base_frequency_hz and order are its schedule's (checked above): written once.
  absl::Status status =
      WriteFormatAttribute(group, kCalibrationFormatName, kCalibrationFormatMajor);
  status.Update(WriteScheduleAttributes(group, table.schedule));
  status.Update(h5::WriteInt64Attribute(group, "takes_averaged", table.takes_averaged));
  if (!status.ok()) return status;
  h5::Id factors = h5::Group(H5Gcreate2(group, "factors", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!factors.valid()) return absl::InternalError("cannot create group factors");
  const hsize_t height = table.geometry.height, width = table.geometry.width;
  const std::vector<hsize_t> planes = {static_cast<hsize_t>(table.order + 1), height, width};
  status.Update(h5::WriteDataset(factors.get(), "real", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, planes,
                                 table.real.data()));
  status.Update(h5::WriteDataset(factors.get(), "imag", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, planes,
                                 table.imag.data()));
  status.Update(h5::WriteDataset(factors.get(), "valid", H5T_STD_U8LE, H5T_NATIVE_UINT8,
                                 {height, width}, table.valid.data()));
  if (!status.ok()) return status;
  return factors.Close();
}

absl::StatusOr<CalibrationTable> ReadCalibrationGroup(hid_t file, absl::string_view file_path,
                                                      const std::string& group_path) {
  absl::StatusOr<h5::Id> group = h5::OpenGroup(file, file_path, group_path);
  if (!group.ok()) return group.status();
  const hid_t id = group->get();
  const std::string where = Where(file_path, group_path);

  if (absl::Status status =
          ReadFormatAttribute(id, where, kCalibrationFormatName, kCalibrationFormatMajor);
      !status.ok()) {
    return status;
  }
  CalibrationTable table;
  absl::StatusOr<ScheduleOptions> schedule =
      ReadScheduleAttributes(id, where, TakesAttribute::kOptional);
  if (!schedule.ok()) return schedule.status();
  if (absl::Status status = schedule->Validate(); !status.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": schedule attributes: ", status.message()));
  }
  table.schedule = *schedule;
  table.base_frequency_hz = schedule->base_frequency_hz;
  table.order = schedule->order;
  absl::StatusOr<int64_t> takes_averaged =
      h5::ReadIntegerAttribute(id, "takes_averaged", where, 0, kMaxTakesAveraged);
  if (!takes_averaged.ok()) return takes_averaged.status();
  table.takes_averaged = static_cast<int>(*takes_averaged);

  const std::string prefix = group_path == "/" ? "" : group_path;
  const std::string real_path = prefix + "/factors/real", imag_path = prefix + "/factors/imag",
                    valid_path = prefix + "/factors/valid";
  std::vector<hsize_t> real_dims, imag_dims, valid_dims;
  absl::StatusOr<h5::Id> real = h5::OpenDataset(file, file_path, real_path, h5::kAnyFloat, 3,
                                                "[m+1, height, width]", &real_dims);
  if (!real.ok()) return real.status();
  const hsize_t height = real_dims[1], width = real_dims[2];
  const hsize_t moments = static_cast<hsize_t>(table.order + 1);
  if (absl::Status status = h5::CheckImageSize(Where(file_path, real_path), height, width);
      !status.ok()) {
    return status;
  }
  if (absl::Status status = h5::CheckShape(Where(file_path, real_path), real_dims,
                                           {moments, height, width}, "[order+1, height, width]");
      !status.ok()) {
    return status;
  }
  absl::StatusOr<h5::Id> imag = h5::OpenDataset(file, file_path, imag_path, h5::kAnyFloat, 3,
                                                "[m+1, height, width]", &imag_dims);
  if (!imag.ok()) return imag.status();
  if (absl::Status status = h5::CheckShape(Where(file_path, imag_path), imag_dims, real_dims,
                                           "[order+1, height, width]");
      !status.ok()) {
    return status;
  }
  absl::StatusOr<h5::Id> valid =
      h5::OpenDataset(file, file_path, valid_path, h5::kByte, 2, "[height, width]", &valid_dims);
  if (!valid.ok()) return valid.status();
  if (absl::Status status = h5::CheckShape(Where(file_path, valid_path), valid_dims,
                                           {height, width}, "[height, width]");
      !status.ok()) {
    return status;
  }
  table.geometry = {.width = static_cast<int>(width), .height = static_cast<int>(height)};
  const int64_t pixels = table.geometry.pixel_count();
  table.real.resize(moments * pixels);
  table.imag.resize(moments * pixels);
  table.valid.resize(pixels);
  if (absl::Status status = h5::ReadDataset(real->get(), H5T_NATIVE_FLOAT, table.real.data(),
                                            Where(file_path, real_path));
      !status.ok()) {
    return status;
  }
  if (absl::Status status = h5::ReadDataset(imag->get(), H5T_NATIVE_FLOAT, table.imag.data(),
                                            Where(file_path, imag_path));
      !status.ok()) {
    return status;
  }
  // The native form of the stored byte type: HDF5 does not convert h5py's bool enum to integers.
  h5::Id valid_type = h5::Datatype(H5Dget_type(valid->get()));
  h5::Id valid_memory = h5::Datatype(H5Tget_native_type(valid_type.get(), H5T_DIR_ASCEND));
  if (absl::Status status = h5::ReadDataset(valid->get(), valid_memory.get(), table.valid.data(),
                                            Where(file_path, valid_path));
      !status.ok()) {
    return status;
  }
  return table;
}

absl::Status WriteCalibrationFile(const std::string& path, const CalibrationTable& table,
                                  CommitMode mode) {
  h5::SilenceErrorStack();
  if (absl::Status status = CheckCalibrationTable(table); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", status.message()));
  }
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path, mode);
  if (!output.ok()) return output.status();
  const std::string& temporary = output->temporary_path();
  h5::Id file = h5::File(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!file.valid()) {
    return absl::InternalError(absl::StrCat(path, ": HDF5 cannot create ", temporary));
  }
  if (absl::Status status = WriteCalibrationGroup(file.get(), table); !status.ok()) {
    return absl::InternalError(absl::StrCat(path, ": ", status.message()));
  }
  if (absl::Status status = file.Close(); !status.ok()) {
    return absl::InternalError(absl::StrCat(path, ": ", status.message()));
  }
  return output->Commit();
}

absl::StatusOr<CalibrationTable> ReadCalibrationFile(const std::string& path) {
  absl::StatusOr<h5::Id> file = h5::OpenFileForReading(path, "an HDF5 calibration file");
  if (!file.ok()) return file.status();
  return ReadCalibrationGroup(file->get(), path, "/");
}

}  // namespace transient

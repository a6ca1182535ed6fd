// Layout checks and typed reads/writes shared by the capture and calibration files.
#include "layout.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "transient/formats/format_tag.h"
#include "transient/reconstruct/moments.h"

namespace transient::internal {

absl::Status CheckReadableHdf5File(const std::string& path) {
  return h5::CheckReadableFile(path);
}

std::string Where(absl::string_view file, absl::string_view object) {
  return absl::StrCat(file, ": ", object);
}

namespace {

using h5::CheckFiltersAvailable;
using h5::OpenObject;

}  // namespace

absl::StatusOr<h5::Id> OpenGroup(hid_t file, absl::string_view file_path,
                                 const std::string& object) {
  return OpenObject(file, file_path, object, H5I_GROUP, "group");
}

absl::StatusOr<h5::Id> OpenDataset(hid_t file, absl::string_view file_path,
                                   const std::string& object, const TypeRule& type, int rank,
                                   absl::string_view shape_description,
                                   std::vector<hsize_t>* dims) {
  absl::StatusOr<h5::Id> dataset =
      OpenObject(file, file_path, object, H5I_DATASET,
                 absl::StrCat("dataset (", type.name, ", ", shape_description, ")"));
  if (!dataset.ok()) return dataset.status();
  const std::string where = Where(file_path, object);
  h5::Id file_type = h5::Datatype(H5Dget_type(dataset->get()));
  const H5T_class_t found_class = H5Tget_class(file_type.get());
  const size_t found_size = H5Tget_size(file_type.get());
  bool class_ok = type.type_class == H5T_NO_CLASS || found_class == type.type_class;
  // h5py writes numpy booleans as a one-byte enum: accept it wherever a byte is expected.
  if (type.type_class == H5T_INTEGER && type.size == 1 && found_class == H5T_ENUM) class_ok = true;
  const bool size_ok = type.size == 0 ? (found_class != H5T_FLOAT || found_size == 4 ||
                                         found_size == 8)
                                      : found_size == type.size;
  if (!class_ok || !size_ok) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": expected ", type.name, ", found ",
                                                   h5::DescribeType(file_type.get())));
  }
  h5::Id space = h5::Dataspace(H5Dget_space(dataset->get()));
  *dims = h5::Dimensions(space.get());
  if (static_cast<int>(dims->size()) != rank) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": expected ", rank, " dimension",
                                                   rank == 1 ? "" : "s", " ", shape_description,
                                                   ", found ", dims->size()));
  }
  if (absl::Status status = CheckFiltersAvailable(dataset->get(), where); !status.ok()) {
    return status;
  }
  return dataset;
}

absl::Status CheckShape(absl::string_view where, const std::vector<hsize_t>& dims,
                        const std::vector<hsize_t>& expected, absl::string_view description) {
  if (dims == expected) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(where, ": expected shape ", description, " = ",
                                                 h5::DimensionsToString(expected), ", found ",
                                                 h5::DimensionsToString(dims)));
}

absl::StatusOr<double> ReadFiniteAttribute(hid_t object, const char* name, absl::string_view where,
                                           Sign sign) {
  absl::StatusOr<double> value = h5::ReadNumericAttribute(object, name, where);
  if (!value.ok()) return value.status();
  const bool ok = std::isfinite(*value) && (sign == Sign::kAny ||
                                            (sign == Sign::kPositive && *value > 0) ||
                                            (sign == Sign::kNonNegative && *value >= 0));
  if (!ok) {
    const char* rule = sign == Sign::kPositive      ? "a finite value > 0"
                       : sign == Sign::kNonNegative ? "a finite value >= 0"
                                                    : "a finite value";
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute ", name, ": expected ", rule, ", found ", *value));
  }
  return value;
}

absl::StatusOr<int64_t> ReadIntegerAttribute(hid_t object, const char* name,
                                             absl::string_view where, int64_t min, int64_t max) {
  absl::StatusOr<double> value = h5::ReadNumericAttribute(object, name, where);
  if (!value.ok()) return value.status();
  if (!(*value >= static_cast<double>(min) && *value <= static_cast<double>(max)) ||
      std::floor(*value) != *value) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": attribute ", name,
                                                   ": expected an integer in ", min, "..", max,
                                                   ", found ", *value));
  }
  return static_cast<int64_t>(*value);
}

absl::StatusOr<std::vector<double>> ReadDoubleArrayAttribute(hid_t object, const char* name,
                                                             absl::string_view where,
                                                             size_t length) {
  if (H5Aexists(object, name) <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": missing attribute ", name));
  }
  h5::Id attribute = h5::Attribute(H5Aopen(object, name, H5P_DEFAULT));
  if (!attribute.valid()) {
    return absl::DataLossError(absl::StrCat(where, ": attribute ", name, ": cannot be opened"));
  }
  h5::Id type = h5::Datatype(H5Aget_type(attribute.get()));
  h5::Id space = h5::Dataspace(H5Aget_space(attribute.get()));
  const std::vector<hsize_t> dims = h5::Dimensions(space.get());
  const H5T_class_t type_class = H5Tget_class(type.get());
  if ((type_class != H5T_FLOAT && type_class != H5T_INTEGER) || dims.size() != 1 ||
      dims[0] != length) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute ", name, ": expected ", length, " float64 values, found ",
                     h5::DescribeType(type.get()), " ", h5::DimensionsToString(dims)));
  }
  std::vector<double> values(length);
  if (H5Aread(attribute.get(), H5T_NATIVE_DOUBLE, values.data()) < 0) {
    return absl::DataLossError(absl::StrCat(where, ": attribute ", name, ": cannot be read"));
  }
  return values;
}

absl::Status WriteDoubleArrayAttribute(hid_t object, const char* name,
                                       const std::vector<double>& values) {
  const hsize_t length = values.size();
  h5::Id space = h5::Dataspace(H5Screate_simple(1, &length, nullptr));
  h5::Id attribute = h5::Attribute(
      H5Acreate2(object, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attribute.valid() || H5Awrite(attribute.get(), H5T_NATIVE_DOUBLE, values.data()) < 0) {
    return absl::InternalError(absl::StrCat("cannot write attribute ", name));
  }
  return attribute.Close();
}

absl::Status WriteDataset(hid_t parent, const char* name, hid_t file_type, hid_t memory_type,
                          const std::vector<hsize_t>& dims, const void* data) {
  h5::Id space = h5::Dataspace(H5Screate_simple(static_cast<int>(dims.size()), dims.data(),
                                                nullptr));
  h5::Id dataset = h5::Dataset(H5Dcreate2(parent, name, file_type, space.get(), H5P_DEFAULT,
                                          H5P_DEFAULT, H5P_DEFAULT));
  if (!dataset.valid() ||
      H5Dwrite(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    return absl::InternalError(absl::StrCat("cannot write dataset ", name));
  }
  return dataset.Close();
}

absl::Status ReadDataset(hid_t dataset, hid_t memory_type, void* data, absl::string_view where) {
  if (H5Dread(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    return absl::DataLossError(absl::StrCat(where, ": cannot be read (corrupt or truncated file)"));
  }
  return absl::OkStatus();
}

absl::Status CheckCalibrationTable(const CalibrationTable& table) {
  const int64_t pixels = table.geometry.pixel_count();
  if (table.geometry.width < 1 || table.geometry.height < 1 || pixels > kMaxFilePixels) {
    return absl::InvalidArgumentError(
        absl::StrCat("calibration geometry = ", table.geometry.width, "x", table.geometry.height,
                     ". Violated constraint: 1 <= width, height and width*height <= ",
                     kMaxFilePixels));
  }
  if (table.order < 1 || table.order > kMaxOrder) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration order = ", table.order, ". Violated constraint: 1 <= order <= ", kMaxOrder));
  }
  if (table.schedule.order != table.order ||
      table.schedule.base_frequency_hz != table.base_frequency_hz) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration order = ", table.order, ", base_frequency_hz = ", table.base_frequency_hz,
        ", schedule order = ", table.schedule.order, ", schedule base_frequency_hz = ",
        table.schedule.base_frequency_hz, ". Violated constraint: the table's order and "
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
    return absl::InvalidArgumentError(absl::StrCat("calibration takes_averaged = ",
                                                   table.takes_averaged,
                                                   ". Violated constraint: takes_averaged >= 0"));
  }
  return absl::OkStatus();
}

absl::Status WriteCalibrationGroup(hid_t group, const CalibrationTable& table) {
  if (absl::Status status = CheckCalibrationTable(table); !status.ok()) return status;
  const ScheduleOptions& schedule = table.schedule;
  absl::Status status = h5::WriteStringAttribute(
      group, "format", FormatTagString(kCalibrationFormatName, kCalibrationFormatMajor));
  status.Update(h5::WriteDoubleAttribute(group, "base_frequency_hz", table.base_frequency_hz));
  status.Update(h5::WriteInt64Attribute(group, "order", table.order));
  status.Update(h5::WriteInt64Attribute(group, "takes_averaged", table.takes_averaged));
  status.Update(h5::WriteInt64Attribute(group, "takes", schedule.takes));
  status.Update(h5::WriteStringAttribute(group, "sampling", SamplingSchemeName(schedule.sampling)));
  status.Update(h5::WriteInt64Attribute(group, "phase_steps", schedule.phase_steps));
  status.Update(h5::WriteStringAttribute(group, "zeroth", ZerothSchemeName(schedule.zeroth)));
  status.Update(h5::WriteDoubleAttribute(group, "proxy_frequency_hz", schedule.proxy_frequency_hz));
  status.Update(h5::WriteDoubleAttribute(group, "exposure_s", schedule.exposure_s));
  if (!status.ok()) return status;
  h5::Id factors = h5::Group(H5Gcreate2(group, "factors", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!factors.valid()) return absl::InternalError("cannot create group factors");
  const hsize_t height = table.geometry.height, width = table.geometry.width;
  const std::vector<hsize_t> planes = {static_cast<hsize_t>(table.order + 1), height, width};
  status.Update(WriteDataset(factors.get(), "real", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, planes,
                             table.real.data()));
  status.Update(WriteDataset(factors.get(), "imag", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, planes,
                             table.imag.data()));
  status.Update(WriteDataset(factors.get(), "valid", H5T_STD_U8LE, H5T_NATIVE_UINT8,
                             {height, width}, table.valid.data()));
  if (!status.ok()) return status;
  return factors.Close();
}

absl::StatusOr<CalibrationTable> ReadCalibrationGroup(hid_t file, absl::string_view file_path,
                                                      const std::string& group_path) {
  absl::StatusOr<h5::Id> group = OpenGroup(file, file_path, group_path);
  if (!group.ok()) return group.status();
  const hid_t id = group->get();
  const std::string where = Where(file_path, group_path);

  absl::StatusOr<std::string> format = h5::ReadStringAttribute(id, "format", where);
  if (!format.ok()) return format.status();
  if (absl::Status tag = CheckFormatTag(*format, kCalibrationFormatName, kCalibrationFormatMajor);
      !tag.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": attribute format: ", tag.message()));
  }
  CalibrationTable table;
  ScheduleOptions& schedule = table.schedule;
  absl::StatusOr<double> frequency =
      ReadFiniteAttribute(id, "base_frequency_hz", where, Sign::kPositive);
  if (!frequency.ok()) return frequency.status();
  absl::StatusOr<int64_t> order = ReadIntegerAttribute(id, "order", where, 1, kMaxOrder);
  if (!order.ok()) return order.status();
  absl::StatusOr<int64_t> takes_averaged =
      ReadIntegerAttribute(id, "takes_averaged", where, 0, int64_t{1} << 40);
  if (!takes_averaged.ok()) return takes_averaged.status();
  // `takes` (the schedule's) came after the first layout draft; older files imply 1.
  int64_t takes = 1;
  if (H5Aexists(id, "takes") > 0) {
    absl::StatusOr<int64_t> value = ReadIntegerAttribute(id, "takes", where, 1, 1 << 20);
    if (!value.ok()) return value.status();
    takes = *value;
  }
  absl::StatusOr<std::string> sampling = h5::ReadStringAttribute(id, "sampling", where);
  if (!sampling.ok()) return sampling.status();
  absl::StatusOr<SamplingScheme> sampling_scheme = ParseSamplingScheme(*sampling);
  if (!sampling_scheme.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute sampling: ", sampling_scheme.status().message()));
  }
  absl::StatusOr<int64_t> phase_steps = ReadIntegerAttribute(id, "phase_steps", where, 1, 1 << 20);
  if (!phase_steps.ok()) return phase_steps.status();
  absl::StatusOr<std::string> zeroth = h5::ReadStringAttribute(id, "zeroth", where);
  if (!zeroth.ok()) return zeroth.status();
  absl::StatusOr<ZerothScheme> zeroth_scheme = ParseZerothScheme(*zeroth);
  if (!zeroth_scheme.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute zeroth: ", zeroth_scheme.status().message()));
  }
  absl::StatusOr<double> proxy =
      ReadFiniteAttribute(id, "proxy_frequency_hz", where, Sign::kNonNegative);
  if (!proxy.ok()) return proxy.status();
  absl::StatusOr<double> exposure = ReadFiniteAttribute(id, "exposure_s", where, Sign::kPositive);
  if (!exposure.ok()) return exposure.status();
  table.base_frequency_hz = *frequency;
  table.order = static_cast<int>(*order);
  table.takes_averaged = static_cast<int>(*takes_averaged);
  schedule = {.base_frequency_hz = *frequency,
              .order = table.order,
              .sampling = *sampling_scheme,
              .phase_steps = static_cast<int>(*phase_steps),
              .zeroth = *zeroth_scheme,
              .proxy_frequency_hz = *proxy,
              .exposure_s = *exposure,
              .takes = static_cast<int>(takes)};
  if (absl::Status status = schedule.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": schedule attributes: ",
                                                   status.message()));
  }

  const std::string prefix = group_path == "/" ? "" : group_path;
  const std::string real_path = prefix + "/factors/real", imag_path = prefix + "/factors/imag",
                    valid_path = prefix + "/factors/valid";
  std::vector<hsize_t> real_dims, imag_dims, valid_dims;
  absl::StatusOr<h5::Id> real =
      OpenDataset(file, file_path, real_path, kAnyFloat, 3, "[m+1, height, width]", &real_dims);
  if (!real.ok()) return real.status();
  const hsize_t height = real_dims[1], width = real_dims[2];
  const hsize_t moments = static_cast<hsize_t>(table.order + 1);
  if (height < 1 || width < 1 || static_cast<int64_t>(height * width) > kMaxFilePixels) {
    return absl::InvalidArgumentError(absl::StrCat(
        Where(file_path, real_path), ": expected 1..", kMaxFilePixels, " pixels, found ",
        h5::DimensionsToString(real_dims)));
  }
  if (absl::Status status = CheckShape(Where(file_path, real_path), real_dims,
                                       {moments, height, width}, "[order+1, height, width]");
      !status.ok()) {
    return status;
  }
  absl::StatusOr<h5::Id> imag =
      OpenDataset(file, file_path, imag_path, kAnyFloat, 3, "[m+1, height, width]", &imag_dims);
  if (!imag.ok()) return imag.status();
  if (absl::Status status = CheckShape(Where(file_path, imag_path), imag_dims, real_dims,
                                       "[order+1, height, width]");
      !status.ok()) {
    return status;
  }
  absl::StatusOr<h5::Id> valid =
      OpenDataset(file, file_path, valid_path, kByte, 2, "[height, width]", &valid_dims);
  if (!valid.ok()) return valid.status();
  if (absl::Status status =
          CheckShape(Where(file_path, valid_path), valid_dims, {height, width}, "[height, width]");
      !status.ok()) {
    return status;
  }
  table.geometry = {.width = static_cast<int>(width), .height = static_cast<int>(height)};
  const int64_t pixels = table.geometry.pixel_count();
  table.real.resize(moments * pixels);
  table.imag.resize(moments * pixels);
  table.valid.resize(pixels);
  if (absl::Status status =
          ReadDataset(real->get(), H5T_NATIVE_FLOAT, table.real.data(), Where(file_path, real_path));
      !status.ok()) {
    return status;
  }
  if (absl::Status status =
          ReadDataset(imag->get(), H5T_NATIVE_FLOAT, table.imag.data(), Where(file_path, imag_path));
      !status.ok()) {
    return status;
  }
  // The native form of the stored byte type: HDF5 does not convert h5py's bool enum to integers.
  h5::Id valid_type = h5::Datatype(H5Dget_type(valid->get()));
  h5::Id valid_memory = h5::Datatype(H5Tget_native_type(valid_type.get(), H5T_DIR_ASCEND));
  if (absl::Status status = ReadDataset(valid->get(), valid_memory.get(), table.valid.data(),
                                        Where(file_path, valid_path));
      !status.ok()) {
    return status;
  }
  return table;
}

}  // namespace transient::internal

// Layout checks and small typed reads/writes shared by the capture and calibration files:
// every error message starts with "<file>: <object>" and names the rule that was broken.
#pragma once

#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/calibration.h"

namespace transient::internal {

// The largest image a file may hold: one image plane is one HDF5 chunk, and HDF5 caps chunks
// below 4 GiB (2^28 float32 pixels = 1 GiB leaves room).
inline constexpr int64_t kMaxFilePixels = int64_t{1} << 28;

// NotFound (no such file), InvalidArgument (a directory, not HDF5), PermissionDenied
// (unreadable), checked before HDF5 sees the path so that each gets its own message.
absl::Status CheckReadableHdf5File(const std::string& path);

// "<file>: <object>", the prefix of every message about `object`.
std::string Where(absl::string_view file, absl::string_view object);

// Opens the group at `object` (absolute path); InvalidArgument when it is missing or another
// kind of object, DataLoss when HDF5 cannot open it.
absl::StatusOr<h5::Id> OpenGroup(hid_t file, absl::string_view file_path, const std::string& object);

// What a dataset must hold. `integer` accepts every integer width (and one-byte enums, h5py's
// bool, when `size` is 1); `floating` accepts float32 and float64 unless `size` pins one.
struct TypeRule {
  H5T_class_t type_class = H5T_FLOAT;  // H5T_NO_CLASS: any type, the caller checks it
  size_t size = 0;  // 0 = any width
  const char* name = "float32";  // what messages call the expected type
};
inline constexpr TypeRule kFloat32{H5T_FLOAT, 4, "float32"};
inline constexpr TypeRule kAnyFloat{H5T_FLOAT, 0, "float32 or float64"};
inline constexpr TypeRule kAnyInteger{H5T_INTEGER, 0, "an integer type"};
inline constexpr TypeRule kByte{H5T_INTEGER, 1, "uint8"};

// Opens dataset `object`, checks its type, its rank (`shape_description` lists the dimension
// names, e.g. "[frames, height, width]") and that the filters it was written with can be
// decoded here. Returns its dimensions in `dims`.
absl::StatusOr<h5::Id> OpenDataset(hid_t file, absl::string_view file_path,
                                   const std::string& object, const TypeRule& type, int rank,
                                   absl::string_view shape_description,
                                   std::vector<hsize_t>* dims);

// InvalidArgument "expected shape <description> = [..], found [..]" unless equal.
absl::Status CheckShape(absl::string_view where, const std::vector<hsize_t>& dims,
                        const std::vector<hsize_t>& expected, absl::string_view description);

// Attribute reads with the checks every caller needs: a finite number (optionally > 0 or
// >= 0), an integer within [min, max], a string, an array of float64 of a given length.
enum class Sign { kAny, kPositive, kNonNegative };
absl::StatusOr<double> ReadFiniteAttribute(hid_t object, const char* name, absl::string_view where,
                                           Sign sign);
absl::StatusOr<int64_t> ReadIntegerAttribute(hid_t object, const char* name,
                                             absl::string_view where, int64_t min, int64_t max);
absl::StatusOr<std::vector<double>> ReadDoubleArrayAttribute(hid_t object, const char* name,
                                                             absl::string_view where,
                                                             size_t length);
absl::Status WriteDoubleArrayAttribute(hid_t object, const char* name,
                                       const std::vector<double>& values);

// Creates dataset `name` in `parent` with the given file type, shape and (optional) chunk
// shape, and writes `data` (memory type `memory_type`) into all of it.
absl::Status WriteDataset(hid_t parent, const char* name, hid_t file_type, hid_t memory_type,
                          const std::vector<hsize_t>& dims, const void* data);

// Reads a whole dataset converted to `memory_type` into `data` (sized by the caller).
absl::Status ReadDataset(hid_t dataset, hid_t memory_type, void* data, absl::string_view where);

// The calibration layout, at the root of a calibration file or under /calibration of a capture:
// attributes format, base_frequency_hz, order, takes_averaged, takes, sampling, phase_steps,
// zeroth, proxy_frequency_hz, exposure_s; datasets factors/real, factors/imag [m+1, H, W]
// float32 and factors/valid [H, W] uint8 (capture_file.h and calibration_file.h document it).
inline constexpr char kCalibrationFormatName[] = "transient-calibration";
inline constexpr int kCalibrationFormatMajor = 1;

// Sizes, order and schedule of a table about to be written; InvalidArgument naming the rule.
absl::Status CheckCalibrationTable(const CalibrationTable& table);
absl::Status WriteCalibrationGroup(hid_t group, const CalibrationTable& table);
// `group_path` is "/" for a calibration file, "/calibration" for a capture.
absl::StatusOr<CalibrationTable> ReadCalibrationGroup(hid_t file, absl::string_view file_path,
                                                      const std::string& group_path);

}  // namespace transient::internal

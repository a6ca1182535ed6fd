// Calibration files: atomic write (temporary file + rename) and validated read.
#include "transient/formats/calibration_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "layout.h"
#include "transient/formats/h5.h"

namespace transient {

absl::Status WriteCalibrationFile(const std::string& path, const CalibrationTable& table) {
  h5::SilenceErrorStack();
  if (absl::Status status = internal::CheckCalibrationTable(table); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", status.message()));
  }
  const std::string temporary = absl::StrCat(path, ".tmp-", getpid());
  const auto fail = [&](absl::Status status) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return status;
  };
  h5::Id file = h5::File(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!file.valid()) {
    // HDF5 hides errno; probe the directory ourselves for a useful code.
    std::FILE* probe = std::fopen(temporary.c_str(), "wb");
    const int reason = probe == nullptr ? errno : 0;
    if (probe != nullptr) std::fclose(probe);
    const std::string message =
        absl::StrCat(path, ": cannot create ", temporary,
                     reason != 0 ? absl::StrCat(" (", std::strerror(reason), ")") : "");
    if (reason == EACCES) return fail(absl::PermissionDeniedError(message));
    if (reason == ENOENT) return fail(absl::NotFoundError(message));
    return fail(absl::InternalError(message));
  }
  if (absl::Status status = internal::WriteCalibrationGroup(file.get(), table); !status.ok()) {
    return fail(absl::InternalError(absl::StrCat(path, ": ", status.message())));
  }
  if (absl::Status status = file.Close(); !status.ok()) {
    return fail(absl::InternalError(absl::StrCat(path, ": ", status.message())));
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const int reason = errno;
    const std::string message = absl::StrCat(path, ": cannot rename ", temporary, " to it (",
                                             std::strerror(reason), ")");
    return fail(reason == EACCES ? absl::PermissionDeniedError(message)
                                 : absl::InternalError(message));
  }
  return absl::OkStatus();
}

absl::StatusOr<CalibrationTable> ReadCalibrationFile(const std::string& path) {
  h5::SilenceErrorStack();
  if (absl::Status status = internal::CheckReadableHdf5File(path); !status.ok()) return status;
  h5::Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!file.valid()) {
    return absl::DataLossError(
        absl::StrCat(path, ": HDF5 cannot open the file (corrupt, truncated or locked)"));
  }
  return internal::ReadCalibrationGroup(file.get(), path, "/");
}

}  // namespace transient

// Temporary-name-then-rename output files.
#include "transient/formats/temporary_output.h"

#include <unistd.h>

#include <filesystem>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"

namespace transient {

absl::StatusOr<TemporaryOutput> TemporaryOutput::Prepare(const std::string& final_path) {
  if (final_path.empty()) return absl::InvalidArgumentError("the output path is empty");
  const std::filesystem::path path(final_path);
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    return absl::InvalidArgumentError(
        absl::StrCat(final_path, ": is a directory, expected the path of the output file"));
  }
  const std::filesystem::path directory =
      path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(directory, error)) {
    return absl::NotFoundError(
        absl::StrCat(final_path, ": directory ", directory.string(), " does not exist"));
  }
  if (::access(directory.c_str(), W_OK) != 0) {
    return absl::PermissionDeniedError(
        absl::StrCat(final_path, ": directory ", directory.string(), " is not writable"));
  }
  return TemporaryOutput(final_path, absl::StrCat(final_path, ".tmp-", ::getpid()));
}

TemporaryOutput::TemporaryOutput(TemporaryOutput&& other) noexcept
    : final_path_(std::move(other.final_path_)),
      temporary_path_(std::move(other.temporary_path_)),
      armed_(std::exchange(other.armed_, false)) {}

TemporaryOutput::~TemporaryOutput() {
  if (!armed_) return;
  std::error_code ignored;  // nothing to report it to; the run has failed already
  std::filesystem::remove(temporary_path_, ignored);
}

absl::Status TemporaryOutput::Commit() {
  std::error_code error;
  std::filesystem::rename(temporary_path_, final_path_, error);
  if (error) {
    return absl::PermissionDeniedError(absl::StrCat(
        final_path_, ": cannot rename ", temporary_path_, " into place (", error.message(), ")"));
  }
  armed_ = false;
  return absl::OkStatus();
}

}  // namespace transient

// Temporary-name-then-rename (or -link) output files (atomic_output.h).
#include "transient/formats/atomic_output.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace transient {
namespace {

constexpr absl::string_view kTemporaryInfix = ".tmp-";

absl::Status ExistsError(absl::string_view final_path) {
  return absl::AlreadyExistsError(
      absl::StrCat(final_path, ": exists; this output never replaces a file"));
}

// The code of a failed rename(2) or link(2) of the temporary file onto the final path.
absl::Status CommitError(int error, const std::string& final_path,
                         const std::string& temporary_path, const char* verb) {
  if (error == EEXIST) return ExistsError(final_path);
  const std::string message = absl::StrCat(final_path, ": cannot ", verb, " ", temporary_path,
                                           " into place (", std::strerror(error), ")");
  switch (error) {
    case ENOENT:
      return absl::NotFoundError(message);
    case EACCES:
    case EPERM:
    case EROFS:
      return absl::PermissionDeniedError(message);
    default:
      return absl::InternalError(message);
  }
}

}  // namespace

absl::StatusOr<AtomicOutput> AtomicOutput::Prepare(const std::string& final_path, CommitMode mode) {
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
  if (mode == CommitMode::kNeverReplace && std::filesystem::symlink_status(path, error).type() !=
                                               std::filesystem::file_type::not_found) {
    return ExistsError(final_path);
  }
  // pid and a counter: unique among processes and among the threads of this one.
  static std::atomic<uint64_t> counter{0};
  std::string temporary =
      absl::StrCat(final_path, kTemporaryInfix, ::getpid(), "-", counter.fetch_add(1));
  return AtomicOutput(final_path, std::move(temporary), mode);
}

AtomicOutput::AtomicOutput(AtomicOutput&& other) noexcept
    : final_path_(std::move(other.final_path_)),
      temporary_path_(std::move(other.temporary_path_)),
      mode_(other.mode_),
      armed_(std::exchange(other.armed_, false)) {}

AtomicOutput::~AtomicOutput() {
  if (!armed_) return;
  std::error_code ignored;  // nothing to report it to; the run has failed already
  std::filesystem::remove(temporary_path_, ignored);
}

absl::Status AtomicOutput::Commit() {
  if (!armed_) {
    return absl::FailedPreconditionError(
        absl::StrCat(final_path_, ": the output was committed already"));
  }
  armed_ = false;
  if (mode_ == CommitMode::kReplace) {
    if (::rename(temporary_path_.c_str(), final_path_.c_str()) == 0) return absl::OkStatus();
    const int error = errno;
    std::error_code ignored;
    std::filesystem::remove(temporary_path_, ignored);
    return CommitError(error, final_path_, temporary_path_, "rename");
  }
  // link(2) fails with EEXIST on an existing name, file or not, so nothing found there is ever
  // replaced, whoever made it and whenever.
  const int error = ::link(temporary_path_.c_str(), final_path_.c_str()) == 0 ? 0 : errno;
  std::error_code ignored;
  std::filesystem::remove(temporary_path_, ignored);
  if (error == 0) return absl::OkStatus();
  return CommitError(error, final_path_, temporary_path_, "link");
}

absl::Status WithFinalPath(const absl::Status& status, absl::string_view final_path) {
  if (status.ok() || final_path.empty()) return status;
  const std::string prefix = absl::StrCat(final_path, kTemporaryInfix);
  const absl::string_view message = status.message();
  std::string out;
  size_t from = 0;
  for (size_t at = message.find(prefix); at != absl::string_view::npos;
       at = message.find(prefix, from)) {
    // "<pid>-<n>": digits, a dash, digits.
    size_t end = at + prefix.size();
    while (end < message.size() &&
           (absl::ascii_isdigit(static_cast<unsigned char>(message[end])) || message[end] == '-')) {
      ++end;
    }
    const bool temporary_name = end > at + prefix.size();
    absl::StrAppend(&out, message.substr(from, at - from),
                    temporary_name ? final_path : message.substr(at, end - at));
    from = end;
  }
  absl::StrAppend(&out, message.substr(from));
  return absl::Status(status.code(), out);
}

absl::Status WriteTextFile(const std::string& path, absl::string_view content, CommitMode mode) {
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path, mode);
  if (!output.ok()) return output.status();
  std::FILE* file = std::fopen(output->temporary_path().c_str(), "wb");
  if (file == nullptr) {
    return absl::PermissionDeniedError(
        absl::StrCat(path, ": cannot create (", std::strerror(errno), ")"));
  }
  const bool written = std::fwrite(content.data(), 1, content.size(), file) == content.size();
  int error = written ? 0 : errno;
  if (std::fclose(file) != 0 && error == 0) error = errno;
  if (!written || error != 0) {
    return absl::ResourceExhaustedError(
        absl::StrCat(path, ": cannot write (", std::strerror(error != 0 ? error : EIO), ")"));
  }
  return output->Commit();
}

}  // namespace transient

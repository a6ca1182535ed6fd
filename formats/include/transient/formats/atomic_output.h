// Writing a file under a temporary name beside its final path and putting it in place only
// when it is complete, so that a failed, interrupted or crashed run leaves no partial output
// behind: a reader of the final path sees the old file or the new one, never half of one.
// Every writer of a finished file goes through here: the tool's reconstruct, moments and
// calibrate commands, WriteCalibrationFile and the daemon's Calibrate.
#pragma once

#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace transient {

// How a complete output takes its final name.
enum class CommitMode {
  // rename(2) over whatever the final path holds: the old file stays whole until the new one
  // replaces it.
  kReplace,
  // link(2) into place, which refuses an existing name, then the temporary name is removed:
  // AlreadyExists when the final path exists, at Prepare or (made meanwhile, by another
  // process or thread) at Commit; the file found there is left untouched.
  kNeverReplace,
};

class AtomicOutput {
 public:
  // Checks that `final_path` can be written (not empty, not a directory, its directory exists
  // and is writable; with kNeverReplace, that it does not exist) and names a temporary file
  // "<final_path>.tmp-<pid>-<n>" beside it, unique in this process; creates nothing.
  // InvalidArgument (empty, a directory), NotFound (no such directory), PermissionDenied (the
  // directory is not writable), AlreadyExists (kNeverReplace, the final path exists).
  [[nodiscard]] static absl::StatusOr<AtomicOutput> Prepare(const std::string& final_path,
                                                            CommitMode mode = CommitMode::kReplace);

  AtomicOutput(AtomicOutput&& other) noexcept;
  AtomicOutput& operator=(AtomicOutput&&) = delete;
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  // Removes the temporary file unless Commit() succeeded: an abandoned output leaves nothing.
  ~AtomicOutput();

  // Where the caller writes (and closes) the file before Commit().
  const std::string& temporary_path() const { return temporary_path_; }
  const std::string& final_path() const { return final_path_; }
  CommitMode mode() const { return mode_; }

  // Puts the closed temporary file at the final path as `mode` says; the temporary name is
  // gone afterwards, whatever the outcome. AlreadyExists (kNeverReplace), NotFound (nothing was
  // written), PermissionDenied, Internal for other failures of the file system;
  // FailedPrecondition when called again.
  absl::Status Commit();

 private:
  AtomicOutput(std::string final_path, std::string temporary_path, CommitMode mode)
      : final_path_(std::move(final_path)),
        temporary_path_(std::move(temporary_path)),
        mode_(mode) {}

  std::string final_path_;
  std::string temporary_path_;
  CommitMode mode_;
  bool armed_ = true;  // the temporary file is ours to remove; false once committed or moved
};

// `status` with every temporary name of `final_path` (as Prepare makes them) in its message
// replaced by `final_path`: errors raised while writing the temporary file name the file the
// user asked for.
absl::Status WithFinalPath(const absl::Status& status, absl::string_view final_path);

// A small text file (JSON, SVG, a summary) written whole through an AtomicOutput. Errors name
// `path`: Prepare's and Commit's codes, ResourceExhausted when the bytes cannot be written
// (a full disk), PermissionDenied when the temporary file cannot be created.
[[nodiscard]] absl::Status WriteTextFile(const std::string& path, absl::string_view content,
                                         CommitMode mode = CommitMode::kReplace);

}  // namespace transient

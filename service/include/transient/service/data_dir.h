// The directory where the daemon writes what clients ask it to write (recordings, calibration
// files), and the quota on it. A client names a new file relative to the directory; nothing a
// client sends can create or change a file anywhere else.
#pragma once

#include <cstdint>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace transient::service {

// Limits on the data directory as a whole; 0 = no limit.
struct DataQuota {
  uint64_t max_bytes = 0;  // bytes of all regular files under the directory
  uint64_t max_files = 0;  // regular files under the directory
};

// Regular files under the directory, counted recursively without following symbolic links.
struct DataUsage {
  uint64_t bytes = 0;
  uint64_t files = 0;
};

class DataDir {
 public:
  // The directory `root`, created (with its parents, under the umask) when missing. InvalidArgument
  // when `root` is empty, names something that is not a directory, or is writable by every
  // user (another could place links or crafted files there); the file system's error
  // (PermissionDenied, ...) naming the path when it cannot be created or read.
  [[nodiscard]] static absl::StatusOr<DataDir> Open(const std::string& root, DataQuota quota);

  // The canonical absolute path of the directory.
  const std::string& root() const { return root_; }
  const DataQuota& quota() const { return quota_; }

  // The absolute path at which a new file `name` may be created. `name` is relative to the
  // directory: components separated by '/', each an existing directory except the last, which
  // must not exist. Refused, with `field` and the name in the message:
  //   InvalidArgument: empty; absolute; a component that is empty, "." or ".."; a control
  //     character; longer than 255 bytes a component or 1024 in all; a directory on the way
  //     that is a symbolic link or not a directory; a last component that is a symbolic link
  //     (dangling or not), a directory or a special file (FIFO, socket, device);
  //   NotFound: a directory on the way does not exist (none is created);
  //   AlreadyExists: a regular file of that name exists (nothing is ever replaced).
  // Only the name is checked here: the writer creates the file with O_EXCL (HDF5's
  // H5F_ACC_EXCL, link(2) of AtomicOutput), which refuses a name made meanwhile, symbolic
  // links included.
  [[nodiscard]] absl::StatusOr<std::string> NewFilePath(absl::string_view field,
                                                        absl::string_view name) const;

  // The absolute path of the existing regular file `name` of the directory, checked as
  // NewFilePath checks names, except that the last component must be a regular file (NotFound
  // when it does not exist). For what a client asks the daemon to read (Calibrate from a
  // `replay:` recording).
  [[nodiscard]] absl::StatusOr<std::string> ExistingFilePath(absl::string_view field,
                                                             absl::string_view name) const;

  // What the directory holds now (a walk of the tree: call it per request, not per frame).
  DataUsage Usage() const;

  // OK when a new file of at least `min_bytes` fits under the quota; ResourceExhausted saying
  // which limit is reached (files, or bytes with the usage and the limit) otherwise.
  absl::Status CheckRoom(uint64_t min_bytes) const;

  // The bytes a file started now may grow to before the quota is reached: max_bytes - usage,
  // 0 when already reached; UINT64_MAX without a byte limit.
  uint64_t BytesLeft() const;

 private:
  absl::StatusOr<std::string> Resolve(absl::string_view field, absl::string_view name,
                                      bool existing) const;

  DataDir(std::string root, DataQuota quota) : root_(std::move(root)), quota_(quota) {}

  std::string root_;
  DataQuota quota_;
};

// The data directory when --data-dir is not given: $XDG_DATA_HOME/transient, else
// $HOME/.local/share/transient, else ./transient-data.
std::string DefaultDataDir();

}  // namespace transient::service

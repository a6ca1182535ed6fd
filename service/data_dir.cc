// The daemon's data directory: names checked component by component with lstat(2), usage by a
// walk that follows no symbolic link.
#include "transient/service/data_dir.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace transient::service {
namespace {

constexpr size_t kMaxComponentBytes = 255;  // NAME_MAX of Linux file systems
constexpr size_t kMaxNameBytes = 1024;

absl::Status FileSystemError(int error, const std::string& what) {
  return absl::ErrnoToStatus(error, what);
}

const char* SpecialKind(mode_t mode) {
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  return "not a regular file";
}

}  // namespace

absl::StatusOr<DataDir> DataDir::Open(const std::string& root, DataQuota quota) {
  if (root.empty()) return absl::InvalidArgumentError("data directory: expected a path");
  std::error_code error;
  if (std::filesystem::exists(root, error) && !std::filesystem::is_directory(root, error)) {
    return absl::InvalidArgumentError(absl::StrCat("data directory ", root, ": not a directory"));
  }
  std::filesystem::create_directories(root, error);
  if (error) {
    return FileSystemError(error.value(),
                           absl::StrCat("data directory ", root, ": cannot be created"));
  }
  const std::filesystem::path canonical = std::filesystem::canonical(root, error);
  if (error) {
    return FileSystemError(error.value(), absl::StrCat("data directory ", root, ": "));
  }
  struct stat info;
  if (::stat(canonical.c_str(), &info) != 0) {
    return FileSystemError(errno, absl::StrCat("data directory ", root));
  }
  if (!S_ISDIR(info.st_mode)) {
    return absl::InvalidArgumentError(absl::StrCat("data directory ", root, ": not a directory"));
  }
  // Another user who may write there could place a link or a crafted file for a client to
  // name (a corrupt HDF5 file can crash the library itself: docs/fuzzing.md).
  if ((info.st_mode & S_IWOTH) != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "data directory ", root, ": writable by every user of the machine (chmod o-w ", root, ")"));
  }
  return DataDir(canonical.string(), quota);
}

absl::StatusOr<std::string> DataDir::NewFilePath(absl::string_view field,
                                                 absl::string_view name) const {
  return Resolve(field, name, /*existing=*/false);
}

absl::StatusOr<std::string> DataDir::ExistingFilePath(absl::string_view field,
                                                      absl::string_view name) const {
  return Resolve(field, name, /*existing=*/true);
}

absl::StatusOr<std::string> DataDir::Resolve(absl::string_view field, absl::string_view name,
                                             bool existing) const {
  const char* const expected = existing
                                   ? "; expected an existing file's name in the data directory"
                                   : "; expected a new file's name relative to the data directory";
  auto refuse = [&](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat(field, " = \"", name, "\": ", why, expected));
  };
  if (name.empty()) return absl::InvalidArgumentError(absl::StrCat(field, ":", expected + 1));
  if (name.size() > kMaxNameBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", name.size(), " bytes long; expected at most ", kMaxNameBytes));
  }
  for (char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      return refuse("a control character");
    }
  }
  if (name.front() == '/') return refuse("an absolute path");
  const std::vector<absl::string_view> components = absl::StrSplit(name, '/');
  for (absl::string_view component : components) {
    if (component.empty()) return refuse("an empty component");
    if (component == "." || component == "..") {
      return refuse(absl::StrCat("a component \"", component, "\""));
    }
    if (component.size() > kMaxComponentBytes) {
      return refuse(absl::StrCat("a component longer than ", kMaxComponentBytes, " bytes"));
    }
  }
  std::string path = root_;
  struct stat info;
  for (size_t i = 0; i < components.size(); ++i) {
    absl::StrAppend(&path, "/", components[i]);
    const bool last = i + 1 == components.size();
    if (::lstat(path.c_str(), &info) != 0) {
      if (errno == ENOENT && last && !existing) return path;
      if (errno == ENOENT) {
        return absl::NotFoundError(absl::StrCat(
            field, " = \"", name, "\": no ", last ? "file" : "directory", " \"",
            absl::string_view(name.data(), static_cast<size_t>(components[i].data() +
                                                               components[i].size() - name.data())),
            "\" in the data directory", last ? "" : " (none is created)"));
      }
      return FileSystemError(errno, absl::StrCat(field, " = \"", name, "\""));
    }
    if (S_ISLNK(info.st_mode)) {
      return refuse(last ? "a symbolic link" : "a symbolic link on the way");
    }
    if (!last) {
      if (!S_ISDIR(info.st_mode)) return refuse("a file on the way is not a directory");
      continue;
    }
    if (S_ISREG(info.st_mode)) {
      if (existing) return path;
      return absl::AlreadyExistsError(absl::StrCat(
          field, " = \"", name, "\": exists in the data directory; nothing is ever replaced"));
    }
    if (S_ISDIR(info.st_mode)) return refuse("a directory");
    return refuse(SpecialKind(info.st_mode));
  }
  return path;  // not reached: the last component returns above
}

DataUsage DataDir::Usage() const {
  DataUsage usage;
  std::error_code error;
  // Errors inside (a directory removed meanwhile, one not readable) skip what they hide: the
  // usage is then an estimate from below, which is what a walk of a changing tree can give.
  for (auto it = std::filesystem::recursive_directory_iterator(
           root_, std::filesystem::directory_options::skip_permission_denied, error);
       !error && it != std::filesystem::recursive_directory_iterator(); it.increment(error)) {
    std::error_code entry_error;
    if (it->is_symlink(entry_error) || !it->is_regular_file(entry_error)) continue;
    const uintmax_t size = it->file_size(entry_error);
    if (entry_error) continue;
    usage.bytes += size;
    ++usage.files;
  }
  return usage;
}

absl::Status DataDir::CheckRoom(uint64_t min_bytes) const {
  if (quota_.max_bytes == 0 && quota_.max_files == 0) return absl::OkStatus();
  const DataUsage usage = Usage();
  if (quota_.max_files > 0 && usage.files >= quota_.max_files) {
    return absl::ResourceExhaustedError(absl::StrCat("the data directory ", root_, " holds ",
                                                     usage.files, " files, its quota is ",
                                                     quota_.max_files));
  }
  if (quota_.max_bytes > 0 &&
      (usage.bytes >= quota_.max_bytes || quota_.max_bytes - usage.bytes < min_bytes)) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the data directory ", root_, " holds ", usage.bytes, " bytes of its quota of ",
        quota_.max_bytes, "; a new file needs at least ", min_bytes));
  }
  return absl::OkStatus();
}

uint64_t DataDir::BytesLeft() const {
  if (quota_.max_bytes == 0) return std::numeric_limits<uint64_t>::max();
  const DataUsage usage = Usage();
  return usage.bytes >= quota_.max_bytes ? 0 : quota_.max_bytes - usage.bytes;
}

std::string DefaultDataDir() {
  if (const char* data_home = std::getenv("XDG_DATA_HOME");
      data_home != nullptr && data_home[0] == '/') {
    return absl::StrCat(data_home, "/transient");
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && home[0] == '/') {
    return absl::StrCat(home, "/.local/share/transient");
  }
  return "transient-data";
}

}  // namespace transient::service

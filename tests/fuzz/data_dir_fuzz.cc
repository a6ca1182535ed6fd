// Names a client gives for a new file (StartRecording's path, Calibrate's output_path) against
// a data directory holding a subdirectory, a file, and symbolic links out of it and within it.
// Property: an accepted name resolves to a path inside the directory, through real
// directories only, at a name that does not exist.
#include <sys/stat.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "absl/strings/match.h"
#include "absl/strings/str_split.h"
#include "tests/fuzz/scratch_directory.h"
#include "transient/service/data_dir.h"

namespace {

const transient::service::DataDir& Directory() {
  static const transient::service::DataDir* directory = [] {
    const std::filesystem::path root =
        transient::fuzz::ScratchDirectoryRemovedAtExit("transient-fuzz-data");
    std::filesystem::create_directories(root / "sub" / "deeper");
    std::ofstream(root / "file.h5") << "x";
    std::filesystem::create_directory_symlink("/tmp", root / "out");
    std::filesystem::create_directory_symlink(root / "sub", root / "sub-link");
    std::filesystem::create_symlink("/etc/passwd", root / "passwd.h5");
    ::mkfifo((root / "fifo").c_str(), 0600);
    absl::StatusOr<transient::service::DataDir> opened =
        transient::service::DataDir::Open(root.string(), {});
    if (!opened.ok()) std::abort();
    return new transient::service::DataDir(*std::move(opened));
  }();
  return *directory;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const transient::service::DataDir& directory = Directory();
  const absl::string_view name(reinterpret_cast<const char*>(data), size);
  absl::StatusOr<std::string> path = directory.NewFilePath("path", name);
  if (!path.ok()) return 0;
  const std::string prefix = directory.root() + "/";
  if (!absl::StartsWith(*path, prefix)) std::abort();
  std::string walked = directory.root();
  for (absl::string_view component : absl::StrSplit(path->substr(prefix.size()), '/')) {
    if (component.empty() || component == "." || component == "..") std::abort();
    walked += "/";
    walked += std::string(component);
    struct stat info;
    const bool exists = ::lstat(walked.c_str(), &info) == 0;
    if (walked == *path) {
      if (exists) std::abort();  // a new file's name only
    } else if (!exists || !S_ISDIR(info.st_mode)) {
      std::abort();  // through real directories only, no symbolic link
    }
  }
  return 0;
}

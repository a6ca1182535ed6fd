// A fresh directory per test under the test temporary directory, removed with its contents.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace transient::testing {

// Named after the running test; tests list it to check that nothing was left behind.
class ScratchDirectory {
 public:
  ScratchDirectory();
  ~ScratchDirectory();
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string File(const std::string& name) const { return (path_ / name).string(); }
  // Names of the entries in the directory, sorted.
  std::vector<std::string> Entries() const;

 private:
  std::filesystem::path path_;
};

}  // namespace transient::testing

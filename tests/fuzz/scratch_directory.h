// A fuzz harness's scratch directory under /tmp, removed with what it holds (a symbolic link
// itself, not what it names) when the process ends. The harnesses build without GoogleTest, so
// tests/support's ScratchDirectory, named after the running test, is not theirs.
#pragma once

#include <stdlib.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace transient::fuzz {

// Creates /tmp/PREFIX-XXXXXX (mkdtemp) and removes it at exit: std::atexit runs the handlers
// registered after this call first, such as one that stops a daemon writing there. Aborts when
// the directory cannot be made.
inline std::filesystem::path ScratchDirectoryRemovedAtExit(const std::string& prefix) {
  static std::vector<std::filesystem::path> roots;
  std::string pattern = "/tmp/" + prefix + "-XXXXXX";
  if (::mkdtemp(pattern.data()) == nullptr) std::abort();
  if (roots.empty()) {
    std::atexit([] {
      std::error_code ignored;
      for (const std::filesystem::path& root : roots) std::filesystem::remove_all(root, ignored);
    });
  }
  roots.emplace_back(pattern);
  return roots.back();
}

}  // namespace transient::fuzz

// What a running command of the `transient` tool reports and obeys: progress, and a flag that
// asks it to stop (SIGINT/SIGTERM in main.cc).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>

namespace transient::tools {

struct CommandHooks {
  // Progress: work done of total (frames or cycles, as the command says).
  std::function<void(int64_t done, int64_t total)> on_progress = nullptr;
  // When it becomes true the command stops at the next frame: a recording is closed and kept
  // (Cancelled is not returned then), other outputs are not written (Cancelled).
  const std::atomic<bool>* cancel = nullptr;

  bool cancelled() const { return cancel != nullptr && cancel->load(); }
  void Progress(int64_t done, int64_t total) const {
    if (on_progress) on_progress(done, total);
  }
};

}  // namespace transient::tools

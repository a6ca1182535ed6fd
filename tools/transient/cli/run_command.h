// Running a subcommand of `transient`: SIGINT/SIGTERM caught into the command's cancel flag, a
// progress bar on a terminal, and its summary or its error printed with the exit code for it.
#pragma once

#include <atomic>
#include <cstdio>
#include <functional>
#include <iostream>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/common/progress_bar.h"

namespace transient::tools::cli {

// From now on the first SIGINT/SIGTERM sets InterruptFlag() (the running command stops and
// cleans up); a second one kills the process at once (the default action is restored).
void CatchInterrupts();
const std::atomic<bool>* InterruptFlag();

// Runs `run` with interrupts caught and a progress bar on stderr; prints format(summary) on
// stdout, or the error line on stderr; returns the exit code.
template <typename Summary>
int RunWithProgress(const std::function<absl::StatusOr<Summary>(const CommandHooks&)>& run,
                    const std::function<std::string(const Summary&)>& format) {
  CatchInterrupts();
  std::unique_ptr<ProgressBar> progress;
  const CommandHooks hooks{
      .on_progress =
          [&](int64_t done, int64_t total) {
            if (progress == nullptr) progress = std::make_unique<ProgressBar>(stderr, total);
            progress->Update(done);
          },
      .cancel = InterruptFlag(),
  };
  absl::StatusOr<Summary> summary = run(hooks);
  progress.reset();  // erase the bar before anything else is printed
  if (!summary.ok()) {
    std::cerr << ErrorLine(summary.status()) << "\n";
    return ExitCodeFor(summary.status());
  }
  std::cout << format(*summary) << "\n";
  return 0;
}

}  // namespace transient::tools::cli

// The interrupt flag of the running command.
#include "tools/transient/cli/run_command.h"

#include <csignal>

namespace transient::tools::cli {
namespace {

std::atomic<bool> interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");

extern "C" void OnInterrupt(int signal_number) {
  interrupted.store(true);
  std::signal(signal_number, SIG_DFL);
}

}  // namespace

void CatchInterrupts() {
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
}

const std::atomic<bool>* InterruptFlag() { return &interrupted; }

}  // namespace transient::tools::cli

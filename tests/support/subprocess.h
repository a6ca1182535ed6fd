// Runs a program as a child process and collects what it printed: the one way the tests start
// the built binaries (transient, transientd) and the system's tools (ffprobe).
#pragma once

#include <string>
#include <vector>

#include "absl/time/time.h"

namespace transient::testing {

struct ProcessResult {
  int exit_code = -1;  // exit status; 128 + N when killed by signal N; -1 when it did not start
  std::string out;     // standard output
  std::string err;     // standard error
};

// Runs `argv` (argv[0] a path, or a name looked up in PATH) with standard input from /dev/null
// and waits for it. Output goes through temporary files, so a child that prints a lot cannot
// block on a full pipe.
ProcessResult RunProcess(const std::vector<std::string>& argv);

// A program running beside the test (a daemon): started with standard input from /dev/null and
// standard output and error appended to `log_path` (or /dev/null when empty); killed with
// SIGKILL and reaped when the object goes without Wait().
class ChildProcess {
 public:
  // started() is false when it could not be started.
  ChildProcess(const std::vector<std::string>& argv, const std::string& log_path = "");
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool started() const { return pid_ > 0; }
  // Sends `signal_number`; false when the process is gone.
  bool Signal(int signal_number);
  // Waits for the process to end: its exit status, 128 + N when killed by signal N, -1 when it
  // was not started or already reaped.
  int Wait();

 private:
  int pid_ = -1;
};

// The port a daemon wrote into `port_file` (transientd --port-file), waiting up to `timeout`
// for it; 0 when none came.
int WaitForPortFile(const std::string& port_file, absl::Duration timeout = absl::Seconds(30));

}  // namespace transient::testing

// Runs a program as a child process and collects what it printed: the one way the tests start
// the built binaries (transient, transientd) and the system's tools (ffprobe).
#pragma once

#include <string>
#include <vector>

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

}  // namespace transient::testing

// `transient bench`: the optimized kernels against the scalar reference in one run, with
// their ratio, on synthetic frames of the thesis's sensor (163x120) and of VGA (640x480); and
// what this machine gives a second thread at the run's start and end.
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/image.h"

namespace transient::tools {

struct BenchArgs {
  std::string json_path;     // also write the rows as JSON here (empty: do not)
  double min_seconds = 0.2;  // per measurement: repeat until this much time has passed
  std::vector<int> threads = {1, 2};

  absl::Status Validate() const;
};

struct BenchRow {
  std::string kernel;  // e.g. "density (256 phases)"
  int order = 0;       // m
  int width = 0, height = 0;
  int threads = 0;                          // of the optimized kernel
  std::string unit;                         // what `reference` and `optimized` count per second
  double reference = 0.0, optimized = 0.0;  // units per second
  double ratio() const { return optimized / reference; }
};

// What the machine itself gives more threads, by two loops that share nothing between threads:
// multiply-adds in registers, and plain stores to a buffer (each thread its own part). Their
// ratios from one thread to more show what the machine gave a second thread in those seconds,
// against which a kernel's own ratio can be read: a virtual machine's second core may be busy
// with another guest, and stores share the caches and the memory.
struct MachineRow {
  std::string probe;  // e.g. "multiply-adds in registers", "stores to a 64 MiB buffer"
  std::string when;   // "start" or "end" of the run
  int threads = 0;
  std::string unit;                              // what the rates count per second
  double one_thread = 0.0, these_threads = 0.0;  // units per second, all threads together
  double ratio() const { return these_threads / one_thread; }
};

struct BenchReport {
  std::vector<BenchRow> rows;
  std::vector<MachineRow> machine;
};

// The benchmark frame: every pixel holds three returns and a small uniform component, like
// the mirrors scene of thesis fig. 8.7, with a little noise so that some pixels need biasing.
// Deterministic (fixed seed); shared with tests/bench so both suites time the same data.
MomentImage MakeBenchFrame(ImageGeometry geometry, int m);

// Runs every measurement; `progress` gets a line per kernel row as it completes.
absl::StatusOr<BenchReport> RunBench(const BenchArgs& args,
                                     void (*progress)(const BenchRow&) = nullptr);

// The probes' work per call: long enough that starting the threads is under 1 % of it (about
// 10 ms a call on one thread of a 2026 server core); the tests ask for less.
struct MachineWork {
  int chain_steps = 1 << 23;                // steps of each of the sixteen multiply-add chains
  size_t buffer_floats = size_t{16} << 20;  // 64 MiB: larger than most L3 caches
  int passes = 8;                           // over the buffer
};

// The machine's rows for `threads` (> 1; a count of 1 has nothing to compare), each probe timed
// for `min_seconds` on one thread and on `threads`.
std::vector<MachineRow> MeasureMachine(const std::string& when, int threads, double min_seconds,
                                       const MachineWork& work = {});

// The report as aligned text tables (the kernels', then the machine's), and as a JSON document.
std::string FormatBenchTable(const BenchReport& report);
std::string FormatBenchJson(const BenchReport& report);

}  // namespace transient::tools

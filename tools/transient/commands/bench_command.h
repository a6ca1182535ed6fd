// `transient bench`: the optimized kernels against the scalar reference in one run, with
// their ratio, on synthetic frames of the thesis's sensor (163x120) and of VGA (640x480).
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

// The benchmark frame: every pixel holds three returns and a small uniform component, like
// the mirrors scene of thesis fig. 8.7, with a little noise so that some pixels need biasing.
// Deterministic (fixed seed); shared with tests/bench so both suites time the same data.
MomentImage MakeBenchFrame(ImageGeometry geometry, int m);

// Runs every measurement; `progress` gets a line per row as it completes.
absl::StatusOr<std::vector<BenchRow>> RunBench(const BenchArgs& args,
                                               void (*progress)(const BenchRow&) = nullptr);

// The rows as an aligned text table, and as a JSON document.
std::string FormatBenchTable(const std::vector<BenchRow>& rows);
std::string FormatBenchJson(const std::vector<BenchRow>& rows);

}  // namespace transient::tools

// `transient eval`: runs the quality benchmark (experiment.h) and writes its report, a Markdown
// table per ground truth (eval.md), the same numbers as JSON (eval.json) and SVG plots in the
// style of thesis fig. 8.12 and 8.13.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/eval/experiment.h"

namespace transient::eval {

// Trials per configuration by default: the whole run takes about 1.5 minutes on the project's
// 2-core machine (measured: 300 trials take 17 s; the time grows linearly).
inline constexpr int kDefaultTrials = 1500;

struct EvalArgs {
  std::string output_dir = "out/eval";
  int trials = kDefaultTrials;
  uint64_t seed = 1;

  // "trials = 0. Violated constraint: trials > 0"; an empty output directory.
  absl::Status Validate() const;
};

struct EvalSummary {
  std::string output_dir;
  std::vector<std::string> files;  // written, relative to output_dir
  int rows = 0;
  double seconds = 0.0;
};

// Validates, creates the output directory (InvalidArgument naming --out when it cannot be
// created or written), runs the experiments and writes the report. Experiment options other than
// trials and seed are the defaults of ExperimentOptions; tests pass their own.
absl::StatusOr<EvalSummary> RunEval(const EvalArgs& args, const ExperimentHooks& hooks = {});
absl::StatusOr<EvalSummary> RunEval(const EvalArgs& args, const ExperimentOptions& options,
                                    const ExperimentHooks& hooks = {});

// The report's parts, exposed for tests.
std::string FormatMarkdown(const ExperimentResult& result, const ExperimentOptions& options);
std::string FormatJson(const ExperimentResult& result, const ExperimentOptions& options);

// "wrote 7 files to out/eval (80 rows, 95.2 s)"
std::string FormatEvalSummary(const EvalSummary& summary);

}  // namespace transient::eval

// `transient eval`: its command line.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <string>
#include "absl/status/status.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/eval/eval_command.h"

namespace transient::tools::cli {
namespace eval_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

CLI::App* AddEvalCommand(CLI::App& app, transient::eval::EvalArgs& args) {
  CLI::App* command = app.add_subcommand(
      "eval",
      "Quality benchmark (thesis fig. 8.12, 8.13): MESE and Pisarenko against single-frequency "
      "phase, Godbaz et al., SPUMIC and SRA on synthetic responses and the simulated corner; "
      "writes eval.md, eval.json and SVG plots.");
  command->add_option("--out", args.output_dir, "directory to write into (created if missing)")
      ->capture_default_str();
  command->add_option("--trials", args.trials, "trials per configuration (> 0)")
      ->capture_default_str();
  command->add_option("--seed", args.seed, "seed of the ground truths and the noise")
      ->capture_default_str();
  return command;
}

int RunEvalCommand(const transient::eval::EvalArgs& args) {
  if (absl::Status status = args.Validate(); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  CatchInterrupts();
  transient::eval::ExperimentHooks hooks;
  hooks.cancel = InterruptFlag();
  hooks.on_stage = [](const std::string& line) { std::cerr << "transient eval: " << line << "\n"; };
  absl::StatusOr<transient::eval::EvalSummary> summary = transient::eval::RunEval(args, hooks);
  if (!summary.ok()) {
    std::cerr << ErrorLine(summary.status()) << "\n";
    return ExitCodeFor(summary.status());
  }
  std::cout << transient::eval::FormatEvalSummary(*summary) << "\n";
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddEvalCommand(app, args_); }
  int Run() override { return RunEvalCommand(args_); }

 private:
  ::transient::eval::EvalArgs args_;
};

}  // namespace eval_cli

std::unique_ptr<Subcommand> MakeEvalCommand() {
  return std::make_unique<eval_cli::Command>();
}

}  // namespace transient::tools::cli

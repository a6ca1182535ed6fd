// `transient bench`: its command line.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <memory>
#include <vector>

#include "absl/status/status.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/commands/bench_command.h"
#include "transient/formats/atomic_output.h"

namespace transient::tools::cli {
namespace bench_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

struct BenchCommandLine {
  ::transient::tools::BenchArgs args;
};

CLI::App* AddBenchCommand(CLI::App& app, BenchCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "bench",
      "Time the optimized kernels against the scalar reference in one run (163x120 and "
      "640x480 synthetic frames) and print their ratio; then what the machine itself gives "
      "the most threads asked (multiply-adds, stores), at the run's start and end.");
  command->add_option("--json", line.args.json_path, "also write the table as JSON here");
  command->add_option("--min-time", line.args.min_seconds, "seconds per measurement")
      ->capture_default_str();
  command->add_option("--threads", line.args.threads, "thread counts of the optimized kernels")
      ->capture_default_str();
  return command;
}

int RunBenchCommand(const BenchCommandLine& line) {
  if (absl::Status status = line.args.Validate(); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  std::fprintf(stderr, "transient bench: reference vs optimized, one row at a time...\n");
  absl::StatusOr<::transient::tools::BenchReport> report =
      ::transient::tools::RunBench(line.args, [](const ::transient::tools::BenchRow& row) {
        std::fprintf(stderr, "  %s, m = %d, %dx%d, %d thread(s): %.1fx\n", row.kernel.c_str(),
                     row.order, row.width, row.height, row.threads, row.ratio());
      });
  if (!report.ok()) {
    std::cerr << ErrorLine(report.status()) << "\n";
    return ExitCodeFor(report.status());
  }
  std::cout << ::transient::tools::FormatBenchTable(*report);
  if (!line.args.json_path.empty()) {
    if (absl::Status status = ::transient::WriteTextFile(
            line.args.json_path, ::transient::tools::FormatBenchJson(*report));
        !status.ok()) {
      std::cerr << ErrorLine(status) << "\n";
      return ExitCodeFor(status);
    }
    std::cout << "wrote " << line.args.json_path << "\n";
  }
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddBenchCommand(app, line_); }
  int Run() override { return RunBenchCommand(line_); }

 private:
  BenchCommandLine line_;
};

}  // namespace bench_cli

std::unique_ptr<Subcommand> MakeBenchCommand() {
  return std::make_unique<bench_cli::Command>();
}

}  // namespace transient::tools::cli

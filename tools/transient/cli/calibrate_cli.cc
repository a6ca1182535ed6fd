// `transient calibrate`: its command line.
#include <CLI/CLI.hpp>

#include <memory>
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/commands/calibrate_command.h"

namespace transient::tools::cli {
namespace calibrate_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

CLI::App* AddCalibrateCommand(CLI::App& app, ::transient::tools::CalibrateArgs& args) {
  CLI::App* command = app.add_subcommand(
      "calibrate",
      "Measure per-pixel, per-harmonic correction factors against a Dirac at zero (thesis "
      "§8.3.2) and write a calibration file (transient-calibration 1). Use the same camera and "
      "schedule as the captures it will correct.");
  command->add_option("--source", args.source_uri,
                      "source looking at a Dirac at zero, e.g. sim:calibration?m=3")
      ->capture_default_str();
  command->add_option("--out", args.output_path, "calibration file to write")->required();
  command->add_option("--takes", args.takes, "capture cycles to average (1..256)")
      ->capture_default_str();
  return command;
}

int RunCalibrateCommand(const ::transient::tools::CalibrateArgs& args) {
  return RunWithProgress<::transient::tools::CalibrateSummary>(
      [&](const ::transient::tools::CommandHooks& hooks) {
        return ::transient::tools::RunCalibrate(args, hooks);
      },
      ::transient::tools::FormatCalibrateSummary);
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddCalibrateCommand(app, args_); }
  int Run() override { return RunCalibrateCommand(args_); }

 private:
  ::transient::tools::CalibrateArgs args_;
};

}  // namespace calibrate_cli

std::unique_ptr<Subcommand> MakeCalibrateCommand() {
  return std::make_unique<calibrate_cli::Command>();
}

}  // namespace transient::tools::cli

// `transient moments`: its command line.
#include <CLI/CLI.hpp>

#include <memory>
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/commands/moments_command.h"

namespace transient::tools::cli {
namespace moments_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

CLI::App* AddMomentsCommand(CLI::App& app, ::transient::tools::MomentsArgs& args) {
  CLI::App* command = app.add_subcommand(
      "moments", "Demodulate and calibrate a capture into a moment file (transient-moments 1) "
                 "for transient reconstruct.");
  command->add_option("capture", args.capture_path, "capture file (transient-capture 1)")
      ->required();
  command->add_option("--out", args.output_path, "moment file to write")->required();
  command->add_option("--calibration", args.calibration_path,
                      "calibration file (default: the one embedded in the capture)");
  command->add_flag("--uncalibrated", args.uncalibrated, "demodulate without a calibration");
  command->add_option("--smooth", args.smoothing_sigma_px,
                      "Gaussian smoothing sigma in pixels, 0 = none (thesis §8.5)")
      ->capture_default_str();
  command->add_flag("--video", args.video,
                    "fill outlier captures from the previous frame and flag them (thesis §8.5)");
  return command;
}

int RunMomentsCommand(const ::transient::tools::MomentsArgs& args) {
  return RunWithProgress<::transient::tools::MomentsSummary>(
      [&](const ::transient::tools::CommandHooks& hooks) {
        return ::transient::tools::RunMoments(args, hooks);
      },
      ::transient::tools::FormatMomentsSummary);
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddMomentsCommand(app, args_); }
  int Run() override { return RunMomentsCommand(args_); }

 private:
  ::transient::tools::MomentsArgs args_;
};

}  // namespace moments_cli

std::unique_ptr<Subcommand> MakeMomentsCommand() {
  return std::make_unique<moments_cli::Command>();
}

}  // namespace transient::tools::cli

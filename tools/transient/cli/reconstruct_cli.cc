// `transient reconstruct`: its command line (options of ReconstructArgs).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include "absl/status/status.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/commands/reconstruct_command.h"
#include "tools/transient/common/progress_bar.h"

namespace transient::tools::cli {
namespace reconstruct_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

// The reconstruct subcommand's options as typed; turned into ReconstructArgs after parsing.
struct ReconstructCommandLine {
  ::transient::tools::ReconstructArgs args;
  std::string method = "both";
  std::string bias_mode = "raise";
  std::string zeroth = "measured";
  CLI::Option* zeroth_option = nullptr;
  double bounds_r = 0.0;
  CLI::Option* bounds_r_option = nullptr;
  std::string frames;
  CLI::Option* frames_option = nullptr;
};

CLI::App* AddReconstructCommand(CLI::App& app, ReconstructCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "reconstruct",
      "Reconstruct a moment file (transient-moments 1) into range, density, cumulative and "
      "Pisarenko images (transient-reconstruction 1). Layouts: README.md.");
  ::transient::tools::ReconstructArgs& args = line.args;
  command->add_option("input", args.input_path, "moment file to read (IN.h5)")->required();
  command
      ->add_option("output", args.output_path,
                   "reconstruction file to write (OUT.h5); replaced only when the run succeeds")
      ->required();
  command->add_option("--method", line.method, "mese, pisarenko or both")->capture_default_str();
  command
      ->add_option("--bins", args.bins,
                   "phases 2*pi*n/N of /density, /cumulative and /bounds (8..65536)")
      ->capture_default_str();
  command
      ->add_option("--bias-epsilon", args.bias_epsilon,
                   "bias so that lambda_min >= E * c_0 (1e-6 <= E < 1)")
      ->capture_default_str();
  command
      ->add_option("--bias-mode", line.bias_mode,
                   "raise (raise c_0) or scale (scale c_1..c_m down)")
      ->capture_default_str();
  line.zeroth_option =
      command
          ->add_option("--zeroth", line.zeroth,
                       "measured (c_0 from the file) or estimate (from c_1..c_m); default: what "
                       "the file's /moments attribute zeroth says, else measured")
          ->capture_default_str();
  command
      ->add_option("--threshold", args.threshold,
                   "a return counts when above T times the pixel's strongest (0 <= T < 1)")
      ->capture_default_str();
  line.bounds_r_option =
      command->add_option("--bounds-r", line.bounds_r,
                          "also write /bounds for the Poisson kernel radius R (0 < R < 1)");
  line.frames_option = command->add_option(
      "--frames", line.frames, "frames A:B to reconstruct, a Python slice (default: all)");
  return command;
}

absl::Status CompleteArgs(ReconstructCommandLine& line) {
  ::transient::tools::ReconstructArgs& args = line.args;
  absl::StatusOr<::transient::tools::Method> method = ::transient::tools::ParseMethod(line.method);
  if (!method.ok()) return method.status();
  args.method = *method;
  absl::StatusOr<transient::BiasMode> bias_mode = ::transient::tools::ParseBiasMode(line.bias_mode);
  if (!bias_mode.ok()) return bias_mode.status();
  args.bias_mode = *bias_mode;
  absl::StatusOr<transient::ZerothMoment> zeroth = ::transient::tools::ParseZeroth(line.zeroth);
  if (!zeroth.ok()) return zeroth.status();
  args.zeroth = *zeroth;
  args.zeroth_from_file = line.zeroth_option->count() == 0;
  if (line.bounds_r_option->count() > 0) args.bounds_r = line.bounds_r;
  if (line.frames_option->count() > 0) {
    absl::StatusOr<::transient::tools::FrameSlice> frames =
        ::transient::tools::ParseFrameSlice(line.frames);
    if (!frames.ok()) return frames.status();
    args.frames = *frames;
  }
  return args.Validate();
}

int RunReconstructCommand(ReconstructCommandLine& line) {
  if (absl::Status status = CompleteArgs(line); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  CatchInterrupts();

  std::unique_ptr<::transient::tools::ProgressBar> progress;
  ::transient::tools::CommandHooks hooks{
      .on_progress =
          [&](int64_t done, int64_t total) {
            if (progress == nullptr) {
              progress = std::make_unique<::transient::tools::ProgressBar>(stderr, total);
            }
            progress->Update(done);
          },
      .cancel = InterruptFlag(),
  };
  absl::StatusOr<::transient::tools::ReconstructSummary> summary =
      ::transient::tools::RunReconstruct(line.args, hooks);
  progress.reset();  // erase the bar before anything else is printed
  if (!summary.ok()) {
    std::cerr << ErrorLine(summary.status()) << "\n";
    return ExitCodeFor(summary.status());
  }
  std::cout << ::transient::tools::FormatSummary(*summary) << "\n";
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddReconstructCommand(app, line_); }
  int Run() override { return RunReconstructCommand(line_); }

 private:
  ReconstructCommandLine line_;
};

}  // namespace reconstruct_cli

std::unique_ptr<Subcommand> MakeReconstructCommand() {
  return std::make_unique<reconstruct_cli::Command>();
}

}  // namespace transient::tools::cli

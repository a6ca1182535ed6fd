// `transient info`: its command line.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <string>
#include "absl/status/status.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/commands/info_command.h"

namespace transient::tools::cli {
namespace info_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

CLI::App* AddInfoCommand(CLI::App& app, std::string& path) {
  CLI::App* command = app.add_subcommand(
      "info", "Say what a file is (capture, calibration, moments, reconstruction), its layout "
              "and a summary of its content.");
  command->add_option("file", path, "HDF5 file")->required();
  return command;
}

int RunInfoCommand(const std::string& path) {
  absl::StatusOr<std::string> text = ::transient::tools::DescribeFile(path);
  if (!text.ok()) {
    std::cerr << ErrorLine(text.status()) << "\n";
    return ExitCodeFor(text.status());
  }
  std::cout << *text << "\n";
  return 0;
}

// The client subcommand's options as typed; turned into ClientArgs after parsing.

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddInfoCommand(app, path_); }
  int Run() override { return RunInfoCommand(path_); }

 private:
  std::string path_;
};

}  // namespace info_cli

std::unique_ptr<Subcommand> MakeInfoCommand() {
  return std::make_unique<info_cli::Command>();
}

}  // namespace transient::tools::cli

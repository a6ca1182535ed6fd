// `transient sources`: its command line.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "transient/drivers/source_registry.h"

namespace transient::tools::cli {
namespace sources_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

CLI::App* AddSourcesCommand(CLI::App& app) {
  return app.add_subcommand(
      "sources", "List the capture source URI schemes, their keys with defaults and units, and "
                 "what each source can do.");
}

int RunSourcesCommand() {
  std::cout << ::transient::DescribeSourceSchemes();
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddSourcesCommand(app); }
  int Run() override { return RunSourcesCommand(); }
};

}  // namespace sources_cli

std::unique_ptr<Subcommand> MakeSourcesCommand() {
  return std::make_unique<sources_cli::Command>();
}

}  // namespace transient::tools::cli

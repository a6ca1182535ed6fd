// The `transient` command line: one subcommand per file in cli/, each mapping its options onto
// a command of the tool library; this file builds the command line and runs the one parsed.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <vector>

#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "transient/wire/frame_memory.h"

namespace transient::tools::cli {

std::vector<std::unique_ptr<Subcommand>> AllSubcommands() {
  std::vector<std::unique_ptr<Subcommand>> all;
  all.push_back(MakeReconstructCommand());
  all.push_back(MakeBenchCommand());
  all.push_back(MakeSimCommand());
  all.push_back(MakeRecordCommand());
  all.push_back(MakeCalibrateCommand());
  all.push_back(MakeMomentsCommand());
  all.push_back(MakeInfoCommand());
  all.push_back(MakeSourcesCommand());
  all.push_back(MakeDevicesCommand());
  all.push_back(MakeClientCommand());
  all.push_back(MakeViewCommand());
  all.push_back(MakeWebCommand());
  all.push_back(MakeWorkerCommand());
  all.push_back(MakeEvalCommand());
  return all;
}

}  // namespace transient::tools::cli

int main(int argc, char** argv) {
  CLI::App app("transient: transient images and depth from AMCW time-of-flight moments",
               "transient");
  app.set_version_flag("--version", TRANSIENT_VERSION);
  app.require_subcommand(1);
  const std::vector<std::unique_ptr<transient::tools::cli::Subcommand>> commands =
      transient::tools::cli::AllSubcommands();
  std::vector<CLI::App*> parsed;
  for (const auto& command : commands) parsed.push_back(command->Add(app));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    if (error.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) {
      return app.exit(error);  // --help, --version
    }
    std::cerr << "error: " << error.what() << " (see transient --help)\n";
    return transient::tools::kExitBadInput;
  }
  // The client, the viewer, the web gateway and the worker receive frames of megabytes at the
  // camera's rate; the file commands allocate images of that size too.
  if (absl::Status heap = transient::wire::KeepFreedFrameMemory(); !heap.ok()) {
    std::cerr << "transient: " << heap.ToString() << "\n";
  }
  for (size_t i = 0; i < commands.size(); ++i) {
    if (parsed[i]->parsed()) return commands[i]->Run();
  }
  return transient::tools::kExitBadInput;  // unreachable: exactly one subcommand is required
}

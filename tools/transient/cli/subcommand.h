// A subcommand of the `transient` tool: it adds itself and its options to the command line, and
// runs what was parsed. One file per subcommand in this folder maps its options onto the
// argument struct of its command (tools/transient/commands/, client/, view/); the files are
// compiled as one unit (CMake UNITY_BUILD) so that CLI11, the slowest header of the build, is
// parsed once.
#pragma once

#include <memory>
#include <vector>

namespace CLI {
class App;
}

namespace transient::tools::cli {

class Subcommand {
 public:
  virtual ~Subcommand() = default;
  // Adds the subcommand and its options to `app`; returns the subcommand's App.
  virtual CLI::App* Add(CLI::App& app) = 0;
  // Runs the parsed subcommand; returns the process's exit code (exit_status.h).
  virtual int Run() = 0;
};

std::unique_ptr<Subcommand> MakeReconstructCommand();
std::unique_ptr<Subcommand> MakeBenchCommand();
std::unique_ptr<Subcommand> MakeSimCommand();
std::unique_ptr<Subcommand> MakeRecordCommand();
std::unique_ptr<Subcommand> MakeCalibrateCommand();
std::unique_ptr<Subcommand> MakeMomentsCommand();
std::unique_ptr<Subcommand> MakeInfoCommand();
std::unique_ptr<Subcommand> MakeSourcesCommand();
std::unique_ptr<Subcommand> MakeDevicesCommand();
std::unique_ptr<Subcommand> MakeClientCommand();
std::unique_ptr<Subcommand> MakeViewCommand();
std::unique_ptr<Subcommand> MakeWebCommand();
std::unique_ptr<Subcommand> MakeWorkerCommand();
std::unique_ptr<Subcommand> MakeEvalCommand();

// Every subcommand, in the order `transient --help` lists them.
std::vector<std::unique_ptr<Subcommand>> AllSubcommands();

}  // namespace transient::tools::cli

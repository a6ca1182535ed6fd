// `transient sim`: its command line: the simulator's keys as options.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/commands/record_command.h"
#include "transient/drivers/simulator.h"

namespace transient::tools::cli {
namespace sim_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

// Keys of the simulator URI that `transient sim` offers as options of their own.
struct SimCommandLine {
  std::string scene;
  ::transient::tools::RecordArgs record;
  int64_t frames = 10;
  std::vector<std::string> keys;  // --set key=value
  // Options mapped onto URI keys when given.
  std::vector<std::pair<std::string, std::string>> options = {
      {"m", ""}, {"f", ""}, {"scheme", ""}, {"nphi", ""}, {"zeroth", ""}, {"takes", ""},
      {"noise", ""}, {"snr", ""}, {"seed", ""}, {"camera_seed", ""}, {"width", ""},
      {"height", ""}, {"waveform", ""}, {"outliers", ""}};
};

std::string SimHelp() {
  std::string text = "Scenes:\n";
  for (const transient::SimulatorScene& scene : transient::SimulatorScenes()) {
    absl::StrAppend(&text, "  ", scene.name, ": ", scene.description, "\n");
  }
  absl::StrAppend(&text, "Keys for --set key=value (URI sim:<scene>?key=value&...):\n");
  for (const transient::SourceKey& key : transient::SimulatorKeys()) {
    absl::StrAppend(&text, "  ", key.name, " (default ", key.default_value,
                    key.unit.empty() ? "" : absl::StrCat(" ", key.unit), "): ", key.description,
                    "\n");
  }
  return text;
}

CLI::App* AddSimCommand(CLI::App& app, SimCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "sim", "Simulate an AMCW camera looking at a scene and record it as a capture file "
             "(transient-capture 1) with the scene's ground truth.");
  command->footer(SimHelp());
  command->add_option("scene", line.scene, "mirrors, corner, sparse, video or calibration")
      ->required();
  command->add_option("--out", line.record.output_path, "capture file to write (must not exist)")
      ->required();
  command->add_option("--frames", line.frames, "transient frames (capture cycles) to simulate")
      ->capture_default_str();
  for (auto& [key, value] : line.options) {
    std::string flag = "--" + key;
    for (char& c : flag) c = c == '_' ? '-' : c;
    command->add_option(flag, value, "the simulator key " + key + " (see below)");
  }
  command->add_option("--set", line.keys, "any simulator key as key=value (repeatable)");
  command->add_option("--deflate", line.record.deflate_level, "deflate level 0..9")
      ->capture_default_str();
  return command;
}

int RunSimCommand(SimCommandLine& line) {
  std::vector<std::string> keys;
  for (const auto& [key, value] : line.options) {
    if (!value.empty()) keys.push_back(key + "=" + value);
  }
  keys.insert(keys.end(), line.keys.begin(), line.keys.end());
  absl::StatusOr<std::string> uri = transient::SimulatorUri(line.scene, line.frames, keys);
  if (!uri.ok()) {
    std::cerr << ErrorLine(uri.status()) << "\n";
    return kExitBadInput;
  }
  line.record.source_uri = *uri;
  line.record.frames = line.frames;
  return RunWithProgress<::transient::tools::RecordSummary>(
      [&](const ::transient::tools::CommandHooks& hooks) {
        return ::transient::tools::RunRecord(line.record, hooks);
      },
      ::transient::tools::FormatRecordSummary);
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddSimCommand(app, line_); }
  int Run() override { return RunSimCommand(line_); }

 private:
  SimCommandLine line_;
};

}  // namespace sim_cli

std::unique_ptr<Subcommand> MakeSimCommand() {
  return std::make_unique<sim_cli::Command>();
}

}  // namespace transient::tools::cli

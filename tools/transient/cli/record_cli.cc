// `transient record`: its command line.
#include <CLI/CLI.hpp>
#include <memory>

#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/security_options.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/commands/record_command.h"
#include "tools/transient/common/exit_status.h"

namespace transient::tools::cli {
namespace record_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

CLI::App* AddRecordCommand(CLI::App& app, ::transient::tools::RecordArgs& args) {
  CLI::App* command = app.add_subcommand(
      "record", "Record raw frames from a source into a capture file (transient-capture 1); "
                "flushed at least once a second, readable after a crash up to the last flush.");
  command->add_option("--source", args.source_uri, "source URI (see transient sources)");
  command->add_option("--nats", args.nats.servers,
                      "instead of --source: NATS servers (nats://HOST:PORT[,...]) whose camera "
                      "stream's MOMENT_STATE frames go into a moment file (transient-moments 1) "
                      "for `transient reconstruct`");
  command->add_option("--nats-camera", args.nats_camera, "the camera's name on NATS")
      ->capture_default_str();
  command
      ->add_option("--nats-start", args.nats_start, "new, all, seq:N, ago:SECONDS or time:RFC3339")
      ->capture_default_str();
  AddNatsSecurityOptions(command, &args.nats);
  command->add_option("--out", args.output_path, "capture file to write (must not exist)")
      ->required();
  command->add_option("--frames", args.frames, "transient frames (capture cycles) to record");
  command->add_option("--seconds", args.seconds, "wall-clock seconds to record");
  command->add_option("--deflate", args.deflate_level, "deflate level 0..9")
      ->capture_default_str();
  return command;
}

int RunRecordCommand(const ::transient::tools::RecordArgs& args) {
  return RunWithProgress<::transient::tools::RecordSummary>(
      [&](const ::transient::tools::CommandHooks& hooks) {
        return ::transient::tools::RunRecord(args, hooks);
      },
      ::transient::tools::FormatRecordSummary);
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddRecordCommand(app, args_); }
  int Run() override { return RunRecordCommand(args_); }

 private:
  ::transient::tools::RecordArgs args_;
};

}  // namespace record_cli

std::unique_ptr<Subcommand> MakeRecordCommand() {
  return std::make_unique<record_cli::Command>();
}

}  // namespace transient::tools::cli

// `transient worker`: a reconstruction worker on NATS JetStream (client/nats_worker.h; README,
// "Many cameras, many machines").
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/security_options.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "transient/client/nats_worker.h"
#include "transient/wire/product_registry.h"

namespace transient::tools::cli {
namespace worker_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;
using ::transient::tools::kExitBadInput;

struct WorkerCommandLine {
  client::NatsWorkerOptions options;
  std::string products = "slices";
  std::string encoding = "float32";
  bool zstd = false;
  double ack_wait_s = 10.0;
  int64_t frames = 0;  // stop after this many; 0 = until interrupted
};

CLI::App* AddWorkerCommand(CLI::App& app, WorkerCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "worker",
      "Share a camera's heavy products with other workers over NATS JetStream: take its "
      "MOMENT_STATE frames (published by transientd --publish) from the group's consumer, "
      "compute slices, cumulative and/or the Pisarenko direct/indirect split, publish them to "
      "transient.<camera>.<product>, and acknowledge each frame once they are stored. Runs "
      "until interrupted.");
  command->footer(
      "Each frame goes to one worker of the group; a frame whose worker dies before\n"
      "acknowledging it goes to another after --ack-wait. Frames must travel in one message\n"
      "(publish with --nats-encoding float16 --nats-zstd, or raise the server's max_payload).\n"
      "Exit codes: 0 stopped (interrupt or --frames), 1 NATS unreachable or failing, 2 bad "
      "options.");
  client::NatsWorkerOptions& o = line.options;
  command->add_option("--nats", o.connect.servers, "NATS servers, nats://HOST:PORT[,...]")
      ->required();
  command->add_option("--nats-camera", o.camera, "the camera's name on NATS")
      ->capture_default_str();
  command->add_option("--group", o.group, "the workers' shared consumer (A-Z a-z 0-9 _ -)")
      ->capture_default_str();
  command->add_option("--products", line.products, "slices, cumulative and/or direct_indirect")
      ->capture_default_str();
  command->add_option("--bins", o.bins, "slices uniform over one modulation period")
      ->capture_default_str();
  command->add_option("--encoding", line.encoding, "float32 or float16")->capture_default_str();
  command->add_flag("--zstd", line.zstd, "compress each image with zstd");
  command
      ->add_option("--ack-wait", line.ack_wait_s,
                   "seconds a taken frame may stay unacknowledged before it goes to another "
                   "worker (set when the group's consumer is made)")
      ->capture_default_str();
  command->add_option("--frames", line.frames, "stop after this many frames (0 = never)");
  AddNatsSecurityOptions(command, &o.connect);
  return command;
}

int RunWorkerCommand(WorkerCommandLine& line) {
  client::NatsWorkerOptions& o = line.options;
  o.products.clear();
  for (absl::string_view name : absl::StrSplit(line.products, ',', absl::SkipWhitespace())) {
    const wire::ProductSpec* spec = wire::FindProduct(name);
    if (spec == nullptr) {
      std::cerr << "transient worker: --products: unknown product '" << name << "'\n";
      return kExitBadInput;
    }
    o.products.push_back(spec->product);
  }
  const std::optional<v1::Encoding> encoding = wire::FindEncoding(line.encoding);
  if (!encoding || *encoding == v1::UINT16_MM) {
    std::cerr << "transient worker: --encoding '" << line.encoding
              << "': expected float32 or float16\n";
    return kExitBadInput;
  }
  o.encoding = *encoding;
  o.compression = line.zstd ? v1::ZSTD : v1::COMPRESSION_NONE;
  o.ack_wait = absl::Seconds(line.ack_wait_s);
  absl::StatusOr<std::unique_ptr<client::NatsWorker>> worker = client::NatsWorker::Open(o);
  if (!worker.ok()) {
    std::cerr << ErrorLine(worker.status()) << "\n";
    return ExitCodeFor(worker.status());
  }
  std::cerr << "transient worker: group " << o.group << " of transient." << o.camera
            << ".moment_state at " << o.connect.servers << "\n";
  CatchInterrupts();
  absl::Time last_report = absl::Now();
  auto report = [&] {
    const client::NatsWorkerCounts& c = (*worker)->counts();
    std::cerr << "transient worker: " << c.frames_done << " frames done (" << c.frames_redelivered
              << " delivered again), " << c.frames_refused << " refused, " << c.publish_failures
              << " publish failures\n";
    if (!(*worker)->last_refusal().ok()) {
      std::cerr << "transient worker: last refused: " << (*worker)->last_refusal().message()
                << "\n";
    }
  };
  while (!InterruptFlag()->load() &&
         (line.frames == 0 || (*worker)->counts().frames_done < line.frames)) {
    absl::StatusOr<bool> took = (*worker)->ProcessOne(absl::Milliseconds(500));
    if (!took.ok()) std::cerr << ErrorLine(took.status()) << "\n";  // the frame comes again
    if (absl::Now() - last_report > absl::Seconds(5)) {
      report();
      last_report = absl::Now();
    }
  }
  report();
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddWorkerCommand(app, line_); }
  int Run() override { return RunWorkerCommand(line_); }

 private:
  WorkerCommandLine line_;
};

}  // namespace worker_cli

std::unique_ptr<Subcommand> MakeWorkerCommand() { return std::make_unique<worker_cli::Command>(); }

}  // namespace transient::tools::cli

// `transient devices`: its command line.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>

#include "tools/transient/cli/subcommand.h"
#include "transient/drivers/capture_devices.h"

namespace transient::tools::cli {
namespace devices_cli {

CLI::App* AddDevicesCommand(CLI::App& app) {
  return app.add_subcommand(
      "devices", "List the capture devices this machine shows (V4L2 nodes with the raw formats "
                 "we read and their ToF controls) with the source URI of each; exits 0 also "
                 "when there are none.");
}

int RunDevicesCommand() {
  std::cout << DescribeCaptureDevices(ListCaptureDevices());
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddDevicesCommand(app); }
  int Run() override { return RunDevicesCommand(); }
};

}  // namespace devices_cli

std::unique_ptr<Subcommand> MakeDevicesCommand() {
  return std::make_unique<devices_cli::Command>();
}

}  // namespace transient::tools::cli

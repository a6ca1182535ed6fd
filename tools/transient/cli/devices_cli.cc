// `transient devices`: its command line.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>

#include "tools/transient/cli/subcommand.h"
#include "transient/drivers/capture_devices.h"

namespace transient::tools::cli {
namespace devices_cli {

CLI::App* AddDevicesCommand(CLI::App& app, DeviceListOptions* options) {
  CLI::App* command = app.add_subcommand(
      "devices", "List the capture devices this machine shows (V4L2 nodes with the raw formats "
                 "we read and their ToF controls, Kinect v2 cameras, OpenNI2 devices) with the "
                 "source URI of each; exits 0 also when there are none.");
  command->add_flag_callback(
      "--no-openni2", [options] { options->openni2 = false; },
      "do not ask OpenNI2 (it loads every driver in its folder, and its USB drivers open the "
      "USB devices they know)");
  return command;
}

int RunDevicesCommand(const DeviceListOptions& options) {
  std::cout << DescribeCaptureDevices(ListCaptureDevices(options), options);
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddDevicesCommand(app, &options_); }
  int Run() override { return RunDevicesCommand(options_); }

 private:
  DeviceListOptions options_;
};

}  // namespace devices_cli

std::unique_ptr<Subcommand> MakeDevicesCommand() {
  return std::make_unique<devices_cli::Command>();
}

}  // namespace transient::tools::cli

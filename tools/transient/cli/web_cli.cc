// `transient web`: the live viewer of a transientd in a browser (web/, docs/web.md).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "tools/transient/cli/run_command.h"
#include "tools/transient/cli/security_options.h"
#include "tools/transient/cli/subcommand.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/common/image_writers.h"
#include "transient/web/gateway.h"
#include "transient/wire/address.h"

namespace transient::tools::cli {
namespace web_cli {

using ::transient::tools::ErrorLine;
using ::transient::tools::ExitCodeFor;

struct WebCommandLine {
  web::GatewayOptions options;
  std::string connect = wire::kDefaultAddress;
};

// The page's files: installed beside the program (PREFIX/share/transient/web), else this
// source tree's web/static.
std::string DefaultStaticDir() {
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const std::filesystem::path installed =
        exe.parent_path().parent_path() / TRANSIENT_INSTALL_DATADIR / "transient" / "web";
    if (std::filesystem::exists(installed / "index.html", error)) return installed.string();
  }
  return TRANSIENT_WEB_STATIC_DIR;
}

// The colour map of every picture of the tool (ColourMap, inferno), 256 steps, for the page.
std::string ColourMapJson() {
  std::string json = "{\"name\":\"inferno\",\"steps\":[";
  for (int i = 0; i < 256; ++i) {
    const ::transient::tools::Rgb8 c = ::transient::tools::ColourMap(i / 255.0f, 1.0f);
    absl::StrAppend(&json, i == 0 ? "" : ",", "[", c.r, ",", c.g, ",", c.b, "]");
  }
  const ::transient::tools::Rgb8 grey = ::transient::tools::kNoValueGrey;
  absl::StrAppend(&json, "],\"noValue\":[", grey.r, ",", grey.g, ",", grey.b, "]}");
  return json;
}

CLI::App* AddWebCommand(CLI::App& app, WebCommandLine& line) {
  CLI::App* command = app.add_subcommand(
      "web",
      "Serve a live viewer of a running transientd to a browser on this machine: range with its "
      "colour bar, amplitude, flags, the transient video, each pixel's transient, stats and "
      "settings (docs/web.md). Prints the page's URL; runs until interrupted.");
  command->footer(
      "The gateway listens on this machine only; to view from another machine, forward the port\n"
      "(ssh -L 8080:127.0.0.1:8080 HOST). The URL it prints carries a key made at start: the page\n"
      "works only with it, since other users of the machine reach the port too. It reaches the\n"
      "daemon with the security options below.\n"
      "Exit codes: 0 stopped by SIGINT/SIGTERM, 1 the port cannot be bound, 2 bad options.");
  web::GatewayOptions& o = line.options;
  AddSecurityOptions(command, &o.daemon.security);
  command->add_option("--connect", line.connect, "address of transientd, host:port or unix:PATH")
      ->capture_default_str();
  command->add_option("--listen", o.listen, "address of the page: 127.0.0.1:PORT (0 picks one)")
      ->capture_default_str();
  command->add_option("--port-file", o.port_file, "write the port actually bound into this file");
  command->add_option("--url-file", o.url_file,
                      "write the page's URL, with its key, into this file (readable by you only "
                      "where the directory is)");
  command->add_option("--bins", o.slice_bins, "slices over one period for the transient video")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  command->add_option("--static-dir", o.static_dir,
                      "the page's files (default: installed beside the program, else the source "
                      "tree's web/static)");
  return command;
}

int RunWebCommand(WebCommandLine& line) {
  web::GatewayOptions& o = line.options;
  o.daemon.address = line.connect;
  if (absl::Status status = o.daemon.Validate(); !status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return kExitBadInput;
  }
  if (o.static_dir.empty()) o.static_dir = DefaultStaticDir();
  o.colour_map_json = ColourMapJson();
  o.log = [](const std::string& text) { std::cerr << text << std::endl; };
  CatchInterrupts();
  const absl::Status status = web::RunGateway(o, InterruptFlag());
  if (!status.ok()) {
    std::cerr << ErrorLine(status) << "\n";
    return ExitCodeFor(status);
  }
  return 0;
}

class Command final : public Subcommand {
 public:
  CLI::App* Add(CLI::App& app) override { return AddWebCommand(app, line_); }
  int Run() override { return RunWebCommand(line_); }

 private:
  WebCommandLine line_;
};

}  // namespace web_cli

std::unique_ptr<Subcommand> MakeWebCommand() { return std::make_unique<web_cli::Command>(); }

}  // namespace transient::tools::cli

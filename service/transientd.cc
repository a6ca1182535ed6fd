// transientd: streams modulated captures from a source through demodulation, calibration and
// the trigonometric-moment reconstruction, and serves transient video and depth over gRPC.
//
//   transientd [--source URI] [--calibration FILE | --uncalibrated] [--listen HOST:PORT]
//              [--config FILE] [--port-file FILE] [--data-dir DIR]
//              [--data-quota BYTES] [--data-quota-files N]
//              [--tls-cert FILE --tls-key FILE] [--client-ca FILE] [--token-file FILE]
//              [--insecure] [--publish nats://HOST:PORT[,...] [--nats-* ...]]
//
// SIGINT/SIGTERM: the recording in progress is closed (readable), streams end, exit 0.

#include <pthread.h>
#include <signal.h>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>

#include "CLI/CLI.hpp"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/drivers/source_registry.h"
#include "transient/formats/calibration_file.h"
#include "transient/service/access.h"
#include "transient/service/data_dir.h"
#include "transient/service/nats_publisher.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/wire/address.h"
#include "transient/wire/frame_memory.h"
#include "transient/wire/product_registry.h"

#ifndef TRANSIENT_VERSION
#define TRANSIENT_VERSION "dev"
#endif

namespace transient::service {
namespace {

constexpr int kStartupCalibrationTakes = 20;

void Log(const std::string& line) {
  std::cerr << absl::FormatTime("%H:%M:%E3S", absl::Now(), absl::LocalTimeZone())
            << " transientd: " << line << std::endl;
}

// The calibration to start with: --calibration FILE; else the one the source carries (a
// recording embeds it); else, when the source has a calibration scene (a simulator), measured
// now from it (thesis §8.3.2); else none. A depth camera (an OpenNI2 device) has none.
absl::Status ChooseCalibration(const std::string& uri, const std::string& file,
                               bool uncalibrated, PipelineOptions* options) {
  if (uncalibrated) return absl::OkStatus();
  if (!file.empty()) {
    absl::StatusOr<CalibrationTable> table = ReadCalibrationFile(file);
    if (!table.ok()) return table.status();
    options->calibration = *std::move(table);
    options->calibration_origin = file;
    return absl::OkStatus();
  }
  absl::StatusOr<const SourceScheme*> scheme = FindSourceScheme(uri);
  if (!scheme.ok()) return absl::OkStatus();  // Pipeline::Create reports it
  if ((*scheme)->capabilities.delivers_depth) return absl::OkStatus();  // nothing to calibrate
  if ((*scheme)->capabilities.embedded_calibration) {
    absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(uri);
    if (!source.ok()) return source.status();
    std::string origin;
    if (const CalibrationTable* table = (*source)->embedded_calibration(&origin)) {
      options->calibration = *table;
      options->calibration_origin = origin;
    } else {
      Log(absl::StrCat(uri, " carries no calibration: moments are uncalibrated"));
    }
    return absl::OkStatus();
  }
  absl::StatusOr<std::string> calibration_uri = CalibrationSourceFor(uri);
  if (!calibration_uri.ok()) {
    Log(absl::StrCat("no calibration for ", uri,
                     " (pass --calibration FILE): moments are uncalibrated"));
    return absl::OkStatus();
  }
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(*calibration_uri);
  if (!source.ok()) return source.status();
  Log(absl::StrCat("calibrating against ", *calibration_uri, ": ", kStartupCalibrationTakes,
                   " takes"));
  absl::StatusOr<CalibrationCapture> measured =
      CaptureCalibration(**source, kStartupCalibrationTakes);
  if (!measured.ok()) return measured.status();
  options->calibration = std::move(measured->table);
  options->calibration_origin = absl::StrCat("measured at start from ", *calibration_uri);
  return absl::OkStatus();
}

int Run(int argc, char** argv) {
  CLI::App app{
      "transientd: transient video and multipath-corrected depth from an AMCW time-of-flight "
      "camera, served over gRPC (transient.v1.Transient; health checking and reflection on)."};
  std::string source_uri = "sim:mirrors";
  std::string calibration_path;
  bool uncalibrated = false;
  std::string listen = wire::kDefaultAddress;
  std::string config_path;
  std::string port_file;
  double stats_interval_s = 10.0;
  std::string data_dir = DefaultDataDir();
  DataQuota quota;
  AccessOptions access_options;
  NatsPublishOptions nats;
  std::string nats_products = "moment_state";
  std::string nats_encoding = "float32";
  bool nats_zstd = false;
  double nats_max_age_s = 3600.0;
  int64_t nats_max_bytes = int64_t{1} << 30;
  app.add_option("--source", source_uri,
                 "capture source URI (the schemes and their keys are listed below, and by "
                 "`transient sources`)")
      ->capture_default_str();
  app.footer(absl::StrCat("Sources:\n", DescribeSourceSchemes()));
  app.add_option("--calibration", calibration_path,
                 "calibration file (transient calibrate); default: a replay's embedded one, or "
                 "for a simulator one measured at start from its calibration scene");
  app.add_flag("--uncalibrated", uncalibrated, "use no calibration at all");
  app.add_option("--listen", listen,
                 "address to serve on, host:port; port 0 picks a free one (see --port-file). "
                 "Loopback by default; another address (0.0.0.0:PORT serves every network) "
                 "needs --tls-cert and --tls-key with --token-file and/or --client-ca, or "
                 "--insecure")
      ->capture_default_str();
  app.add_option("--config", config_path,
                 "reconstruction settings, `key = value` lines: range_method (mese|pisarenko), "
                 "bias_epsilon, threshold, smoothing_sigma_px, takes, video (true|false); and "
                 "publish, nats_camera, ... as the --publish and --nats-* options (which win)");
  app.add_option("--port-file", port_file, "write the port actually bound into this file");
  app.add_option("--data-dir", data_dir,
                 "directory of the recordings and calibration files clients ask for: they name "
                 "new files relative to it, and nothing is written elsewhere (created if "
                 "missing)")
      ->capture_default_str();
  app.add_option("--data-quota", quota.max_bytes,
                 "most bytes the data directory may hold, e.g. 20GB or 512MiB; a recording "
                 "stops before its file would pass it, and new files are refused beyond it "
                 "(0 = no limit)")
      ->transform(CLI::AsSizeValue(/*kb_is_1000=*/true));
  app.add_option("--data-quota-files", quota.max_files,
                 "most files the data directory may hold (0 = no limit)");
  app.add_option("--tls-cert", access_options.tls_cert_file,
                 "serve TLS with this PEM certificate (chain); needs --tls-key");
  app.add_option("--tls-key", access_options.tls_key_file,
                 "the PEM private key of --tls-cert (not readable by others)");
  app.add_option("--client-ca", access_options.client_ca_file,
                 "every call needs a client certificate signed by this PEM CA (mutual TLS)");
  app.add_option("--token-file", access_options.token_file,
                 "every call needs `authorization: Bearer TOKEN`, TOKEN being this file's "
                 "content (16..4096 printable bytes, not readable by others; e.g. "
                 "`openssl rand -hex 32 > FILE`)");
  app.add_flag("--insecure", access_options.insecure,
               "allow --listen on a non-loopback address without TLS and authentication: anyone "
               "who reaches the port may record, calibrate and reconfigure");
  app.add_option("--publish", nats.connect.servers,
                 "also publish each frame's products to NATS JetStream at these servers "
                 "(nats://HOST:PORT or tls://HOST:PORT, comma-separated: one cluster), to "
                 "subjects transient.<camera>.<product> kept by the stream TRANSIENT_<camera>");
  app.add_option("--nats-camera", nats.camera,
                 "the camera's name in the subjects and the stream (A-Z a-z 0-9 _ -)")
      ->capture_default_str();
  app.add_option("--nats-products", nats_products,
                 "comma-separated products to publish (as `transient client --products`); "
                 "moment_state carries every other product's input")
      ->capture_default_str();
  app.add_option("--nats-encoding", nats_encoding, "float32, float16 or mm (range and depth)")
      ->capture_default_str();
  app.add_flag("--nats-zstd", nats_zstd, "compress each image with zstd");
  app.add_option("--nats-max-age", nats_max_age_s,
                 "seconds the stream keeps a frame (0 = no limit)")
      ->capture_default_str();
  app.add_option("--nats-max-bytes", nats_max_bytes,
                 "bytes the stream keeps, oldest frames removed first, e.g. 1GiB (0 = no limit)")
      ->transform(CLI::AsSizeValue(/*kb_is_1000=*/true));
  app.add_option("--nats-replicas", nats.replicas,
                 "copies of the stream a NATS cluster keeps (1..5)")
      ->capture_default_str();
  app.add_option("--nats-user-file", nats.connect.user_file,
                 "a file holding user:password for the NATS server (not readable by others)");
  app.add_option("--nats-creds", nats.connect.creds_file,
                 "a NATS .creds file (user JWT and nkey seed; not readable by others)");
  app.add_option("--nats-ca", nats.connect.ca_file,
                 "PEM CA of the NATS server's certificate (TLS)");
  app.add_option("--nats-cert", nats.connect.cert_file,
                 "PEM client certificate for the NATS server, with --nats-key");
  app.add_option("--nats-key", nats.connect.key_file, "the PEM key of --nats-cert");
  app.add_option("--stats-interval", stats_interval_s, "seconds between stats lines in the log")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.set_version_flag("--version", TRANSIENT_VERSION);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (uncalibrated && !calibration_path.empty()) {
    std::cerr << "transientd: --uncalibrated and --calibration exclude each other\n";
    return 2;
  }

  // Before any thread starts: frames of megabytes, allocated and freed at the camera's rate.
  if (absl::Status heap = wire::KeepFreedFrameMemory(); !heap.ok()) Log(heap.ToString());

  // Signals are taken by sigwait below: every thread started from here on blocks them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // A write past RLIMIT_FSIZE fails with EFBIG, as one on a full disk fails with ENOSPC, and
  // ends the recording it belongs to; the signal would end the daemon.
  signal(SIGXFSZ, SIG_IGN);

  absl::StatusOr<Access> access = Access::Load(access_options, listen);
  if (!access.ok()) {
    std::cerr << "transientd: " << access.status().message() << "\n";
    return 2;
  }
  auto shared_access = std::make_shared<const Access>(*std::move(access));
  // The config file: reconstruction settings, and the daemon's NATS keys, which the command
  // line overrides.
  ReconstructionConfig file_config;
  if (!config_path.empty()) {
    DaemonKeys keys;
    if (absl::Status status = ReadConfigFile(config_path, &file_config, &keys); !status.ok()) {
      std::cerr << "transientd: " << status.message() << "\n";
      return 2;
    }
    for (const auto& [key, value] : keys) {
      const std::string flag = absl::StrCat("--", absl::StrReplaceAll(key, {{"_", "-"}}));
      if (app.count(flag) > 0) continue;  // the command line says otherwise
      bool ok = true;
      if (key == "publish")
        nats.connect.servers = value;
      else if (key == "nats_camera")
        nats.camera = value;
      else if (key == "nats_products")
        nats_products = value;
      else if (key == "nats_encoding")
        nats_encoding = value;
      else if (key == "nats_zstd")
        ok = absl::SimpleAtob(value, &nats_zstd);
      else if (key == "nats_max_age")
        ok = absl::SimpleAtod(value, &nats_max_age_s);
      else if (key == "nats_max_bytes")
        ok = absl::SimpleAtoi(value, &nats_max_bytes);
      else if (key == "nats_replicas")
        ok = absl::SimpleAtoi(value, &nats.replicas);
      else if (key == "nats_user_file")
        nats.connect.user_file = value;
      else if (key == "nats_creds")
        nats.connect.creds_file = value;
      else if (key == "nats_ca")
        nats.connect.ca_file = value;
      else if (key == "nats_cert")
        nats.connect.cert_file = value;
      else if (key == "nats_key")
        nats.connect.key_file = value;
      if (!ok) {
        std::cerr << "transientd: " << config_path << ": " << key << " = " << value << ": expected "
                  << (key == "nats_zstd" ? "true or false" : "a number") << "\n";
        return 2;
      }
    }
  }
  // The NATS options are checked before anything starts (a calibration takes seconds).
  if (!nats.connect.servers.empty()) {
    if (absl::Status status = wire::CheckNatsCameraName(nats.camera); !status.ok()) {
      std::cerr << "transientd: --nats-camera: " << status.message() << "\n";
      return 2;
    }
    for (absl::string_view name : absl::StrSplit(nats_products, ',', absl::SkipWhitespace())) {
      const wire::ProductSpec* spec = wire::FindProduct(name);
      if (spec == nullptr) {
        std::cerr << "transientd: --nats-products: unknown product '" << name << "'\n";
        return 2;
      }
      nats.request.add_products(spec->product);
    }
    const std::optional<v1::Encoding> encoding = wire::FindEncoding(nats_encoding);
    if (!encoding) {
      std::cerr << "transientd: --nats-encoding '" << nats_encoding
                << "': expected float32, float16 or mm\n";
      return 2;
    }
    nats.request.set_encoding(*encoding);
    nats.request.set_compression(nats_zstd ? v1::ZSTD : v1::COMPRESSION_NONE);
    if (nats.replicas < 1 || nats.replicas > 5 || !(nats_max_age_s >= 0.0)) {
      std::cerr << "transientd: --nats-replicas " << nats.replicas << " / --nats-max-age "
                << nats_max_age_s << ": expected replicas 1..5 and an age >= 0 s\n";
      return 2;
    }
    nats.max_age = absl::Seconds(nats_max_age_s);
    nats.max_bytes = nats_max_bytes;
  }
  absl::StatusOr<DataDir> data = DataDir::Open(data_dir, quota);
  if (!data.ok()) {
    std::cerr << "transientd: --data-dir: " << data.status().message() << "\n";
    return 2;
  }

  PipelineOptions options;
  options.source_uri = source_uri;
  options.data_dir = std::make_shared<const DataDir>(*std::move(data));
  const std::string data_dir_root = options.data_dir->root();
  options.log = Log;
  options.stats_log_interval = absl::Seconds(stats_interval_s);
  options.config = file_config;
  if (absl::Status status =
          ChooseCalibration(source_uri, calibration_path, uncalibrated, &options);
      !status.ok()) {
    std::cerr << "transientd: " << status.message() << "\n";
    return 2;
  }
  const int requested_takes = options.config.takes;
  absl::StatusOr<std::unique_ptr<Pipeline>> pipeline = Pipeline::Create(std::move(options));
  if (!pipeline.ok()) {
    std::cerr << "transientd: " << pipeline.status().message() << "\n";
    return 2;
  }
  if (!config_path.empty() && requested_takes != (*pipeline)->config().takes) {
    ReconstructionConfig config = (*pipeline)->config();
    config.takes = requested_takes;
    if (absl::Status status = (*pipeline)->SetConfig(config); !status.ok()) {
      std::cerr << "transientd: " << config_path << ": " << status.message() << "\n";
      return 2;
    }
  }
  std::unique_ptr<NatsPublisher> publisher;
  if (!nats.connect.servers.empty()) {
    absl::StatusOr<std::unique_ptr<NatsPublisher>> started =
        NatsPublisher::Start(pipeline->get(), nats);
    if (!started.ok()) {
      std::cerr << "transientd: --publish: " << started.status().message() << "\n";
      return 2;
    }
    publisher = *std::move(started);
    const NatsPublishStats n = publisher->Stats();
    Log(absl::StrCat("publishing to NATS at ", n.servers, " (",
                     n.connected ? "connected" : "not reachable yet, retrying", "): subjects ",
                     wire::NatsCameraSubjects(nats.camera), ", stream ",
                     wire::NatsStreamName(nats.camera)));
  }
  absl::StatusOr<std::unique_ptr<TransientServer>> server =
      TransientServer::Start(pipeline->get(), {.listen = listen,
                                               .version = TRANSIENT_VERSION,
                                               .access = shared_access,
                                               .nats = publisher.get()});
  if (!server.ok()) {
    std::cerr << "transientd: " << server.status().message() << "\n";
    return 2;
  }
  (*pipeline)->Start();
  Log(absl::StrCat("serving ", (*pipeline)->source_uri(), " (", (*pipeline)->camera().geometry.width,
                   "x", (*pipeline)->camera().geometry.height, ", ",
                   (*pipeline)->schedule().Describe(), "; calibration: ",
                   (*pipeline)->calibration_origin(), ") on ", (*server)->address(),
                   "; access: ", shared_access->Describe(), "; files of clients go to ",
                   data_dir_root));
  if (!port_file.empty()) {
    // Written whole under a temporary name, so that a reader never sees a partial port.
    const std::string partial = port_file + ".partial";
    std::ofstream(partial) << (*server)->port() << "\n";
    std::rename(partial.c_str(), port_file.c_str());
  }

  int signal_number = 0;
  sigwait(&signals, &signal_number);
  Log(absl::StrCat(signal_number == SIGINT ? "SIGINT" : "SIGTERM",
                   ": closing the recording, ending streams"));
  (*pipeline)->Stop();
  (*server)->Shutdown(absl::Seconds(2));
  if (publisher != nullptr) publisher->Stop();
  Log("stopped");
  return 0;
}

}  // namespace
}  // namespace transient::service

int main(int argc, char** argv) { return transient::service::Run(argc, argv); }

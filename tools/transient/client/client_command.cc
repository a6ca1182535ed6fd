// `transient client`: a gRPC subscriber of transientd that measures the stream and writes the
// products of its last frame as PNG/TIFF images and summary.json.
#include "tools/transient/client/client_command.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <utility>

#include "absl/algorithm/container.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "tools/transient/client/product_images.h"
#include "tools/transient/common/run_length.h"
#include "transient/client/client.h"
#include "transient/client/decoded_image.h"
#include "transient/client/frame_stream.h"
#include "transient/client/nats_stream.h"
#include "transient/formats/atomic_output.h"
#include "transient/reconstruct/percentile.h"
#include "transient/reconstruct/status_context.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/image_codec.h"
#include "transient/wire/product_registry.h"

namespace transient::tools {
namespace {

namespace fs = std::filesystem;

using ::transient::client::DecodedImage;

std::string EncodingChoiceNames() {
  std::vector<std::string> names;
  for (const wire::EncodingChoice& choice : wire::EncodingChoices()) names.push_back(choice.name);
  const std::string last = names.back();
  names.pop_back();
  return absl::StrCat(absl::StrJoin(names, ", "), " or ", last);
}

std::vector<v1::Product> RequestedProducts(const std::vector<std::string>& names) {
  std::vector<v1::Product> products;
  for (const std::string& name : names) {
    const v1::Product product = wire::FindProduct(name)->product;
    if (std::find(products.begin(), products.end(), product) == products.end()) {
      products.push_back(product);
    }
  }
  return products;
}

}  // namespace

absl::StatusOr<ClientRoi> ParseRoi(const std::string& text) {
  const std::vector<std::string> parts = absl::StrSplit(text, ',');
  int values[4] = {};
  bool ok = parts.size() == 4;
  for (size_t i = 0; ok && i < parts.size(); ++i) {
    ok = absl::SimpleAtoi(parts[i], &values[i]) && values[i] >= 0;
  }
  if (!ok) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--roi '", text, "': expected X,Y,W,H in pixels (four integers >= 0)"));
  }
  return ClientRoi{.x = values[0], .y = values[1], .width = values[2], .height = values[3]};
}

absl::Status ClientArgs::Validate() const {
  if (connect.empty()) {
    return absl::InvalidArgumentError("--connect: expected an address such as 127.0.0.1:50051");
  }
  if (products.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--products: expected at least one of ", absl::StrJoin(wire::ProductNames(), ", ")));
  }
  std::vector<std::string> unknown;
  for (const std::string& name : products) {
    if (wire::FindProduct(name) == nullptr) unknown.push_back(absl::StrCat("'", name, "'"));
  }
  if (!unknown.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--products: unknown product", unknown.size() > 1 ? "s " : " ",
                     absl::StrJoin(unknown, ", "), "; valid: ",
                     absl::StrJoin(wire::ProductNames(), ", ")));
  }
  if (absl::Status status = ValidateRunLength(frames, seconds); !status.ok()) return status;
  if (output_dir.empty()) return absl::InvalidArgumentError("--out: expected a directory");
  if ((roi.width == 0) != (roi.height == 0) || roi.x < 0 || roi.y < 0 || roi.width < 0 ||
      roi.height < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--roi ", roi.x, ",", roi.y, ",", roi.width, ",", roi.height,
                     ": expected width and height both > 0, or both 0 for the whole sensor"));
  }
  if (bins < 1 || bins > wire::kMaxSlices) {
    return absl::InvalidArgumentError(
        absl::StrCat("--bins = ", bins, ": expected 1..", wire::kMaxSlices));
  }
  const std::optional<v1::Encoding> wire_encoding = wire::FindEncoding(encoding);
  if (!wire_encoding) {
    return absl::InvalidArgumentError(
        absl::StrCat("--encoding '", encoding, "': expected ", EncodingChoiceNames()));
  }
  for (const v1::Product product : RequestedProducts(products)) {
    if (absl::Status status = wire::CheckEncoding(product, *wire_encoding); !status.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--encoding ", encoding, " does not fit --products ", ProductStem(product),
                       " (mm is for range and depth only): ", status.message()));
    }
  }
  if (!(max_rate_hz >= 0.0) || !std::isfinite(max_rate_hz)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--max-rate = ", max_rate_hz, ": expected >= 0 (0 = every frame)"));
  }
  if (!(connect_timeout_s > 0.0) || !std::isfinite(connect_timeout_s)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--connect-timeout = ", connect_timeout_s, ": expected > 0 seconds"));
  }
  if (!(moment_near_m == 0.0 && moment_far_m == 0.0)) {
    if (!std::isfinite(moment_near_m) || moment_near_m < 0.0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--moment-near = ", moment_near_m, ": expected a finite depth >= 0 m"));
    }
    if (!std::isfinite(moment_far_m) || !(moment_far_m > moment_near_m)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--moment-far = ", moment_far_m, ": expected a depth above --moment-near = ",
                       moment_near_m, " m (or both 0 for the daemon's default)"));
    }
  }
  if (moment_sigma_px && (!std::isfinite(*moment_sigma_px) || *moment_sigma_px < 0.0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--moment-sigma = ", *moment_sigma_px, ": expected >= 0 px (0 = no filter)"));
  }
  if (moment_bits != 64 && moment_bits != 128) {
    return absl::InvalidArgumentError(
        absl::StrCat("--moment-bits = ", moment_bits, ": expected 64 or 128"));
  }
  if (!nats.servers.empty()) {
    if (absl::StatusOr<std::vector<std::string>> servers = wire::ParseNatsServers(nats.servers);
        !servers.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("--nats: ", servers.status().message()));
    }
    if (absl::Status status = wire::CheckNatsCameraName(nats_camera); !status.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("--nats-camera: ", status.message()));
    }
    if (RequestedProducts(products).size() != 1) {
      return absl::InvalidArgumentError(
          "--products: with --nats, exactly one (each product has its own subject)");
    }
    client::NatsStreamOptions start;
    if (absl::Status status = client::ParseNatsStart("--nats-start", nats_start, &start);
        !status.ok()) {
      return status;
    }
  }
  if (virtual_plane_m && (!std::isfinite(*virtual_plane_m) || !(*virtual_plane_m > 0.0))) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--virtual-plane = ", *virtual_plane_m, ": expected a depth > 0 m"));
  }
  return absl::OkStatus();
}

absl::StatusOr<ClientSummary> RunClient(const ClientArgs& args, const CommandHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  const std::vector<v1::Product> products = RequestedProducts(args.products);

  // The output directory is checked before anything is received, so that nothing is lost to
  // a typo at the end.
  const fs::path dir(args.output_dir);
  std::error_code dir_error;
  fs::create_directories(dir, dir_error);
  if (dir_error || !fs::is_directory(dir)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--out ", args.output_dir, ": cannot create the directory",
        dir_error ? absl::StrCat(": ", dir_error.message()) : std::string(" (a file is there)")));
  }

  ClientSummary summary;
  summary.address = args.connect;
  summary.output_dir = args.output_dir;

  // gRPC: the daemon itself; --nats: a camera's subject on NATS JetStream, no daemon to ask.
  const bool over_nats = !args.nats.servers.empty();
  std::optional<client::Client> daemon;
  if (over_nats) {
    summary.address = absl::StrCat("nats:", args.nats.servers);
    summary.source_uri = wire::NatsSubject(args.nats_camera, products.front());
  } else {
    absl::StatusOr<client::Client> connected =
        client::Client::Connect({.address = args.connect,
                                 .security = args.security,
                                 .timeout_s = args.connect_timeout_s,
                                 .cancel = hooks.cancel});
    if (!connected.ok()) return connected.status();
    daemon.emplace(*std::move(connected));
    absl::StatusOr<v1::Info> got_info = daemon->GetInfo();
    if (!got_info.ok()) return got_info.status();
    const v1::Info& info = *got_info;
    summary.source_uri = info.source_uri();
    summary.version = info.version();
    summary.camera_width = static_cast<int>(std::min<uint32_t>(info.camera().width(), INT32_MAX));
    summary.camera_height = static_cast<int>(std::min<uint32_t>(info.camera().height(), INT32_MAX));
    if (info.products_size() > 0) {
      std::vector<std::string> missing;
      for (const v1::Product product : products) {
        if (std::find(info.products().begin(), info.products().end(), product) ==
            info.products().end()) {
          missing.push_back(ProductStem(product));
        }
      }
      if (!missing.empty()) {
        std::vector<std::string> offered;
        for (const int product : info.products()) {
          offered.push_back(ProductStem(product));
        }
        return absl::InvalidArgumentError(absl::StrCat(
            "--products ", absl::StrJoin(missing, ","), ": not offered by transientd at ",
            args.connect, " (it offers ", absl::StrJoin(offered, ", "), ")"));
      }
    }
  }

  v1::StreamRequest request;
  for (const v1::Product product : products) request.add_products(product);
  request.mutable_roi()->set_x(static_cast<uint32_t>(args.roi.x));
  request.mutable_roi()->set_y(static_cast<uint32_t>(args.roi.y));
  request.mutable_roi()->set_width(static_cast<uint32_t>(args.roi.width));
  request.mutable_roi()->set_height(static_cast<uint32_t>(args.roi.height));
  request.set_max_rate_hz(args.max_rate_hz);
  request.set_encoding(*wire::FindEncoding(args.encoding));
  request.set_compression(args.zstd ? v1::ZSTD : v1::COMPRESSION_NONE);
  request.mutable_slices()->set_bins(static_cast<uint32_t>(args.bins));
  if (absl::c_linear_search(products, v1::MOMENT_DEPTH)) {
    v1::MomentDepthRequest* moments = request.mutable_moment_depth();
    moments->set_near_m(args.moment_near_m);
    moments->set_far_m(args.moment_far_m);
    if (args.moment_sigma_px) moments->set_sigma_px(*args.moment_sigma_px);
    moments->set_bits(static_cast<uint32_t>(args.moment_bits));
    moments->set_from_returns(args.moment_from_returns);
  }

  const int64_t target =
      args.frames > 0 ? args.frames : std::numeric_limits<int64_t>::max();  // else --seconds
  std::vector<double> latencies_ms;
  std::vector<DecodedImage> last_images;
  absl::Time first_arrival, last_arrival;
  const absl::Time opened = absl::Now();
  const absl::Time deadline =
      args.seconds > 0.0 ? opened + absl::Seconds(args.seconds) : absl::InfiniteFuture();
  std::unique_ptr<client::FrameStream> grpc_stream;
  std::unique_ptr<client::NatsFrameStream> nats_stream;
  if (over_nats) {
    client::NatsStreamOptions options;
    options.connect = args.nats;
    options.camera = args.nats_camera;
    options.product = products.front();
    (void)client::ParseNatsStart("--nats-start", args.nats_start, &options);  // Validate checked
    options.cancel = hooks.cancel;
    options.deadline = deadline;
    absl::StatusOr<std::unique_ptr<client::NatsFrameStream>> opened_nats =
        client::NatsFrameStream::Open(options);
    if (!opened_nats.ok()) return opened_nats.status();
    nats_stream = *std::move(opened_nats);
  } else {
    grpc_stream = daemon->StreamFrames(request, {.cancel = hooks.cancel, .deadline = deadline});
  }
  // One loop for both transports: they yield the same StreamFrame.
  const auto next = [&](client::StreamFrame* f) {
    return grpc_stream != nullptr ? grpc_stream->Next(f) : nats_stream->Next(f);
  };
  const auto counts = [&]() -> const client::StreamCounts& {
    return grpc_stream != nullptr ? grpc_stream->counts() : nats_stream->counts();
  };
  // Frames with images, corrupt ones included: they count towards --frames as they arrive.
  const auto received = [&] { return counts().frames + counts().corrupt; };
  client::StreamFrame frame;
  while (received() < target && !hooks.cancelled() && next(&frame)) {
    switch (frame.kind) {
      case client::StreamFrame::Kind::kAnnouncement:
        summary.state_changes.push_back(
            {.after_frames = counts().frames, .state = v1::SourceState_Name(frame.state)});
        continue;
      case client::StreamFrame::Kind::kCorrupt:
        break;  // dropped; counted by the stream
      case client::StreamFrame::Kind::kImages:
        last_images = std::move(frame.images);
        if (counts().frames == 1) first_arrival = frame.arrival;
        if (over_nats && summary.camera_width == 0 && !last_images.empty()) {
          summary.camera_width = last_images.front().geometry.width;  // what was published
          summary.camera_height = last_images.front().geometry.height;
        }
        last_arrival = frame.arrival;
        if (std::isfinite(frame.latency_s)) latencies_ms.push_back(1e3 * frame.latency_s);
        break;
    }
    hooks.Progress(received(), args.frames);
  }
  // OK when the daemon ended it cleanly or we did (enough frames, --seconds); Cancelled when
  // interrupted; otherwise the daemon's status.
  const absl::Status end = grpc_stream != nullptr ? grpc_stream->Finish() : nats_stream->Finish();
  const bool interrupted = hooks.cancelled();
  summary.frames = counts().frames;
  summary.corrupt_frames = counts().corrupt;
  summary.state_announcements = counts().announcements;
  summary.frames_missed = counts().missed;
  // The source's own counters at the end (a camera's dropped sequences); none when the daemon
  // is gone or not asked (NATS).
  if (absl::StatusOr<v1::Stats> stats =
          daemon ? daemon->GetStats() : absl::StatusOr<v1::Stats>(absl::UnavailableError(""));
      stats.ok()) {
    std::vector<std::pair<std::string, int64_t>> counters;
    for (const v1::SourceCounter& c : stats->source_counters()) {
      counters.emplace_back(c.name(), c.value());
    }
    summary.source_counters = std::move(counters);
  }
  summary.interrupted = interrupted;
  summary.seconds = absl::ToDoubleSeconds((summary.frames > 0 ? last_arrival : absl::Now()) -
                                          opened);
  if (summary.frames >= 2 && last_arrival > first_arrival) {
    summary.rate_hz =
        static_cast<double>(summary.frames - 1) / absl::ToDoubleSeconds(last_arrival - first_arrival);
  }
  if (latencies_ms.empty()) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    summary.latency = {nan, nan, nan, nan};
  } else {
    summary.latency.p50_ms = Percentile(std::span<double>(latencies_ms), 50.0);
    summary.latency.p90_ms = Percentile(std::span<double>(latencies_ms), 90.0);
    summary.latency.p99_ms = Percentile(std::span<double>(latencies_ms), 99.0);
    summary.latency.max_ms = Percentile(std::span<double>(latencies_ms), 100.0);
  }
  absl::Status stream_error;
  if (!end.ok() && !(interrupted && end.code() == absl::StatusCode::kCancelled)) {
    stream_error = end;
    summary.stream_error = std::string(stream_error.message());
  }

  absl::Status written =
      WriteProductImages(dir, last_images, products, args.virtual_plane_m, &summary);
  const std::string summary_path = (dir / "summary.json").string();
  if (written.ok()) {
    summary.files.push_back("summary.json");
    written = WriteTextFile(summary_path, ClientSummaryJson(summary));
    if (!written.ok()) summary.files.pop_back();
  } else {
    // The summary still says how far the stream got, and why the files are missing.
    (void)WriteTextFile(summary_path, ClientSummaryJson(summary));
  }

  if (!stream_error.ok()) {
    return WithContext(
        absl::StrCat("stream from ", over_nats ? summary.address : "transientd at " + args.connect,
                     " failed after ", summary.frames,
                     " frames (what arrived is in ", args.output_dir, ")"),
        written.ok() ? stream_error
                     : absl::Status(stream_error.code(),
                                    absl::StrCat(stream_error.message(),
                                                 "; and writing failed: ", written.message())));
  }
  if (!written.ok()) return written;
  if (interrupted) {
    return absl::CancelledError(absl::StrCat("interrupted after ", summary.frames,
                                             " frames; what arrived is in ", args.output_dir));
  }
  return summary;
}

}  // namespace transient::tools

// `transient client`: a gRPC subscriber of transientd that measures the stream and writes the
// products of its last frame as PNG/TIFF images and summary.json.
#include "tools/transient/client_command.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "tools/transient/image_writers.h"
#include "transient/reconstruct/percentile.h"
#include "transient/client/client.h"
#include "transient/client/decoded_image.h"
#include "transient/client/frame_stream.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/image_codec.h"
#include "transient/wire/product_registry.h"

namespace transient::tools {
namespace {

namespace fs = std::filesystem;

using ::transient::client::DecodedImage;

// The slice and cumulative images use this percentile of their finite values as full colour:
// a few hot pixels (a specular return) do not wash out the rest of the sweep.
constexpr double kColourScalePercentile = 99.5;

// The folder and file stem of a product: its registry name, or product_<n> for a value the
// registry does not know (a newer daemon's, in GetInfo).
std::string ProductStem(int product) {
  const wire::ProductSpec* spec = wire::FindProduct(static_cast<v1::Product>(product));
  return spec != nullptr ? spec->name : absl::StrCat("product_", product);
}

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

bool Contains(const std::vector<v1::Product>& products, v1::Product product) {
  return std::find(products.begin(), products.end(), product) != products.end();
}

bool Cancelled(const CommandHooks& hooks) {
  return hooks.cancel != nullptr && hooks.cancel->load();
}

absl::Status Prefixed(absl::string_view prefix, const absl::Status& status) {
  return absl::Status(status.code(), absl::StrCat(prefix, status.message()));
}

// Writes one group of images of the same product; appends the files to summary->files.
class ProductWriter {
 public:
  ProductWriter(fs::path dir, const std::vector<v1::Product>& requested, ClientSummary* summary,
                std::optional<double> virtual_plane_m = std::nullopt)
      : dir_(std::move(dir)),
        requested_(requested),
        summary_(summary),
        virtual_plane_m_(virtual_plane_m) {}

  absl::Status Write(v1::Product product, const std::vector<const DecodedImage*>& images) {
    const DecodedImage& first = *images.front();
    switch (product) {
      case v1::RANGE:
        if (absl::Status status = Tiff("range.tiff", first); !status.ok()) return status;
        if (!Contains(requested_, v1::DEPTH)) return Millimetres("range_mm.png", first);
        return absl::OkStatus();
      case v1::DEPTH:
        return Millimetres("depth.png", first);
      case v1::AMPLITUDE:
        return Tiff("amplitude.tiff", first);
      case v1::C0:
        return Tiff("c0.tiff", first);
      case v1::FLAGS:
        return Flags("flags.png", first);
      case v1::SLICES:
        return Series("slices", images, &summary_->slice_scale);
      case v1::CUMULATIVE:
        return Series("cumulative", images, &summary_->cumulative_scale);
      case v1::MOMENT_DEPTH:
        return MomentDepth(first);
      default:
        return Planes(ProductStem(product), images);
    }
  }

  // Writes `text` to dir/name; the caller lists the file (summary.json lists itself).
  absl::Status WriteText(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::FILE* file = std::fopen(path.c_str(), "w");
    if (file == nullptr) return absl::ErrnoToStatus(errno, absl::StrCat(path, ": cannot create"));
    const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
    int error_number = errno;
    const bool closed = std::fclose(file) == 0;
    if (!closed) error_number = errno;
    if (!written || !closed) {
      return absl::ErrnoToStatus(error_number != 0 ? error_number : EIO,
                                 absl::StrCat(path, ": cannot write"));
    }
    return absl::OkStatus();
  }

 private:
  absl::Status Done(const std::string& name, absl::Status status) {
    if (status.ok()) summary_->files.push_back(name);
    return status;
  }

  absl::Status Tiff(const std::string& name, const DecodedImage& image) {
    return Done(name, WriteTiffFloat((dir_ / name).string(), image.geometry, image.values));
  }

  absl::Status Millimetres(const std::string& name, const DecodedImage& image) {
    std::vector<uint16_t> millimetres(image.values.size());
    std::transform(image.values.begin(), image.values.end(), millimetres.begin(),
                   MetresToMillimetres);
    return Done(name, WritePng16((dir_ / name).string(), image.geometry, millimetres));
  }

  absl::Status Flags(const std::string& name, const DecodedImage& image) {
    std::vector<uint8_t> bits(image.values.size());
    std::transform(image.values.begin(), image.values.end(), bits.begin(), [](float value) {
      return std::isfinite(value) ? static_cast<uint8_t>(std::clamp(value, 0.0f, 255.0f)) : 0;
    });
    return Done(name, WritePng8((dir_ / name).string(), image.geometry, bits));
  }

  // The decoded moments b1..b4 as float TIFFs, and the occlusion of the virtual plane.
  absl::Status MomentDepth(const DecodedImage& image) {
    if (!image.moment_depth) return absl::InternalError("moment_depth image without its map");
    const MomentDepthMap& map = *image.moment_depth;
    if (absl::Status status = MakeFolder("moment_depth"); !status.ok()) return status;
    const int64_t pixels = map.geometry.pixel_count();
    std::vector<float> plane(static_cast<size_t>(pixels));
    for (int j = 1; j <= 4; ++j) {
      for (int64_t p = 0; p < pixels; ++p) {
        plane[p] = map.Texel(static_cast<int>(p % map.geometry.width),
                             static_cast<int>(p / map.geometry.width))[j];
      }
      const std::string name = absl::StrCat("moment_depth/b", j, ".tiff");
      if (absl::Status status =
              Done(name, WriteTiffFloat((dir_ / name).string(), map.geometry, plane));
          !status.ok()) {
        return status;
      }
    }
    const double plane_m = virtual_plane_m_.value_or(0.5 * (map.options.normalisation.near_m +
                                                            map.options.normalisation.far_m));
    std::vector<uint8_t> occlusion(static_cast<size_t>(pixels));
    double sum = 0.0;
    for (int64_t p = 0; p < pixels; ++p) {
      const float fraction = map.Occlusion(static_cast<int>(p % map.geometry.width),
                                           static_cast<int>(p / map.geometry.width), plane_m);
      sum += fraction;
      occlusion[p] = static_cast<uint8_t>(std::lround(255.0f * std::clamp(fraction, 0.0f, 1.0f)));
    }
    summary_->moment_depth = ClientSummary::MomentDepth{
        .bits = map.options.format == MomentMapFormat::kOptimized64 ? 64 : 128,
        .near_m = map.options.normalisation.near_m,
        .far_m = map.options.normalisation.far_m,
        .sigma_px = map.options.sigma_px,
        .from_returns = image.moment_depth_from_returns,
        .empty_pixels = map.empty_texels,
        .virtual_plane_m = plane_m,
        .occluded_share = sum / static_cast<double>(pixels)};
    const std::string name = "moment_depth/occlusion_plane.png";
    return Done(name, WritePng8((dir_ / name).string(), map.geometry, occlusion));
  }

  absl::Status MakeFolder(const std::string& folder) {
    std::error_code error;
    fs::create_directories(dir_ / folder, error);
    if (error) {
      return absl::ErrnoToStatus(error.value(),
                                 absl::StrCat((dir_ / folder).string(), ": cannot create"));
    }
    return absl::OkStatus();
  }

  // One colour scale for the whole series, so that brightness compares across slices.
  absl::Status Series(const std::string& folder, const std::vector<const DecodedImage*>& images,
                      float* scale_out) {
    std::vector<float> finite;
    for (const DecodedImage* image : images) {
      std::copy_if(image->values.begin(), image->values.end(), std::back_inserter(finite),
                   [](float value) { return std::isfinite(value); });
    }
    const double percentile = Percentile(std::span<float>(finite), kColourScalePercentile);
    const float scale = percentile > 0.0 && std::isfinite(percentile)
                            ? static_cast<float>(percentile)
                            : 1.0f;
    *scale_out = scale;
    if (absl::Status status = MakeFolder(folder); !status.ok()) return status;
    for (size_t i = 0; i < images.size(); ++i) {
      const std::string name = absl::StrFormat("%s/slice_%03d.png", folder, i);
      const DecodedImage& image = *images[i];
      absl::Status status = WritePngRgb8((dir_ / name).string(), image.geometry,
                                         ColourMapPlane(image.values, scale));
      if (absl::Status done = Done(name, std::move(status)); !done.ok()) return done;
    }
    return absl::OkStatus();
  }

  // Image names come from the network: only [A-Za-z0-9._-] reach the file system.
  static std::string SafeName(const std::string& name) {
    std::string safe = name;
    for (char& c : safe) {
      if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' &&
          c != '_') {
        c = '_';
      }
    }
    return safe;
  }

  absl::Status Planes(const std::string& stem, const std::vector<const DecodedImage*>& images) {
    if (images.size() == 1) return Tiff(stem + ".tiff", *images.front());
    if (absl::Status status = MakeFolder(stem); !status.ok()) return status;
    for (size_t i = 0; i < images.size(); ++i) {
      const std::string name =
          absl::StrFormat("%s/%03d_%s.tiff", stem, i, SafeName(images[i]->name));
      if (absl::Status status = Tiff(name, *images[i]); !status.ok()) return status;
    }
    return absl::OkStatus();
  }

  fs::path dir_;
  const std::vector<v1::Product>& requested_;
  ClientSummary* summary_;
  std::optional<double> virtual_plane_m_;
};

absl::Status WriteProducts(const fs::path& dir, const std::vector<DecodedImage>& images,
                           const std::vector<v1::Product>& requested,
                           std::optional<double> virtual_plane_m, ClientSummary* summary) {
  // Products in the order they arrived, each with its planes in order.
  std::vector<std::pair<v1::Product, std::vector<const DecodedImage*>>> groups;
  for (const DecodedImage& image : images) {
    if (!Contains(requested, image.product)) continue;  // not asked for: not ours to write
    auto group = std::find_if(groups.begin(), groups.end(),
                              [&](const auto& entry) { return entry.first == image.product; });
    if (group == groups.end()) {
      groups.push_back({image.product, {}});
      group = std::prev(groups.end());
    }
    group->second.push_back(&image);
  }
  for (const auto& [product, group] : groups) {
    if (product == v1::SLICES ||
        (product == v1::CUMULATIVE && !Contains(requested, v1::SLICES))) {
      summary->slice_time_of_flight_ns.clear();
      for (const DecodedImage* image : group) {
        summary->slice_time_of_flight_ns.push_back(image->time_of_flight_ns);
      }
    }
  }
  ProductWriter writer(dir, requested, summary, virtual_plane_m);
  for (const auto& [product, group] : groups) {
    if (absl::Status status = writer.Write(product, group); !status.ok()) return status;
  }
  return absl::OkStatus();
}

std::string JsonString(absl::string_view text) {
  std::string json = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        json += "\\\"";
        break;
      case '\\':
        json += "\\\\";
        break;
      case '\n':
        json += "\\n";
        break;
      case '\r':
        json += "\\r";
        break;
      case '\t':
        json += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          absl::StrAppendFormat(&json, "\\u%04x", static_cast<int>(c));
        } else {
          json += c;
        }
    }
  }
  return json + "\"";
}

// JSON has no NaN or infinity: they become null.
std::string JsonNumber(double value) {
  if (!std::isfinite(value)) return "null";
  return absl::StrFormat("%.10g", value);
}

std::string JsonStrings(const std::vector<std::string>& values) {
  std::vector<std::string> quoted;
  for (const std::string& value : values) quoted.push_back(JsonString(value));
  return absl::StrCat("[", absl::StrJoin(quoted, ", "), "]");
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
  if (frames < 0) {
    return absl::InvalidArgumentError(absl::StrCat("--frames = ", frames, ": expected >= 1"));
  }
  if (!(seconds >= 0.0) || !std::isfinite(seconds)) {
    return absl::InvalidArgumentError(absl::StrCat("--seconds = ", seconds, ": expected > 0"));
  }
  if ((frames > 0) == (seconds > 0.0)) {
    return absl::InvalidArgumentError("give exactly one of --frames N and --seconds S");
  }
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

  absl::StatusOr<client::Client> daemon = client::Client::Connect(
      {.address = args.connect, .timeout_s = args.connect_timeout_s, .cancel = hooks.cancel});
  if (!daemon.ok()) return daemon.status();
  absl::StatusOr<v1::Info> got_info = daemon->GetInfo();
  if (!got_info.ok()) return got_info.status();
  const v1::Info& info = *got_info;
  summary.source_uri = info.source_uri();
  summary.version = info.version();
  summary.camera_width = static_cast<int>(std::min<uint32_t>(info.camera().width(), INT32_MAX));
  summary.camera_height =
      static_cast<int>(std::min<uint32_t>(info.camera().height(), INT32_MAX));
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
  if (Contains(products, v1::MOMENT_DEPTH)) {
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
  std::unique_ptr<client::FrameStream> stream = daemon->StreamFrames(
      request, {.cancel = hooks.cancel,
                .deadline = args.seconds > 0.0 ? opened + absl::Seconds(args.seconds)
                                               : absl::InfiniteFuture()});
  // Frames with images, corrupt ones included: they count towards --frames as they arrive.
  const auto received = [&stream] {
    return stream->counts().frames + stream->counts().corrupt;
  };
  client::StreamFrame frame;
  while (received() < target && !Cancelled(hooks) && stream->Next(&frame)) {
    switch (frame.kind) {
      case client::StreamFrame::Kind::kAnnouncement:
        summary.state_changes.push_back({.after_frames = stream->counts().frames,
                                         .state = v1::SourceState_Name(frame.state)});
        continue;
      case client::StreamFrame::Kind::kCorrupt:
        break;  // dropped; counted by the stream
      case client::StreamFrame::Kind::kImages:
        last_images = std::move(frame.images);
        if (stream->counts().frames == 1) first_arrival = frame.arrival;
        last_arrival = frame.arrival;
        if (std::isfinite(frame.latency_s)) latencies_ms.push_back(1e3 * frame.latency_s);
        break;
    }
    if (hooks.on_progress) hooks.on_progress(received(), args.frames);
  }
  // OK when the daemon ended it cleanly or we did (enough frames, --seconds); Cancelled when
  // interrupted; otherwise the daemon's status.
  const absl::Status end = stream->Finish();
  const bool interrupted = Cancelled(hooks);
  summary.frames = stream->counts().frames;
  summary.corrupt_frames = stream->counts().corrupt;
  summary.state_announcements = stream->counts().announcements;
  summary.frames_missed = stream->counts().missed;
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
      WriteProducts(dir, last_images, products, args.virtual_plane_m, &summary);
  ProductWriter json_writer(dir, products, &summary);
  if (written.ok()) {
    summary.files.push_back("summary.json");
    written = json_writer.WriteText("summary.json", ClientSummaryJson(summary));
    if (!written.ok()) summary.files.pop_back();
  } else {
    // The summary still says how far the stream got, and why the files are missing.
    (void)json_writer.WriteText("summary.json", ClientSummaryJson(summary));
  }

  if (!stream_error.ok()) {
    return Prefixed(
        absl::StrCat("stream from transientd at ", args.connect, " failed after ",
                     summary.frames, " frames (what arrived is in ", args.output_dir, "): "),
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

std::string ClientSummaryJson(const ClientSummary& summary) {
  std::string json = "{\n";
  absl::StrAppend(&json, "  \"address\": ", JsonString(summary.address), ",\n");
  absl::StrAppend(&json, "  \"source_uri\": ", JsonString(summary.source_uri), ",\n");
  absl::StrAppend(&json, "  \"daemon_version\": ", JsonString(summary.version), ",\n");
  absl::StrAppend(&json, "  \"camera\": {\"width\": ", summary.camera_width,
                  ", \"height\": ", summary.camera_height, "},\n");
  absl::StrAppend(&json, "  \"frames\": ", summary.frames, ",\n");
  absl::StrAppend(&json, "  \"corrupt_frames\": ", summary.corrupt_frames, ",\n");
  absl::StrAppend(&json, "  \"state_announcements\": ", summary.state_announcements, ",\n");
  absl::StrAppend(&json, "  \"seconds\": ", JsonNumber(summary.seconds), ",\n");
  absl::StrAppend(&json, "  \"rate_hz\": ", JsonNumber(summary.rate_hz), ",\n");
  absl::StrAppend(&json, "  \"latency_ms\": {\"p50\": ", JsonNumber(summary.latency.p50_ms),
                  ", \"p90\": ", JsonNumber(summary.latency.p90_ms),
                  ", \"p99\": ", JsonNumber(summary.latency.p99_ms),
                  ", \"max\": ", JsonNumber(summary.latency.max_ms), "},\n");
  absl::StrAppend(&json, "  \"frames_missed\": ", summary.frames_missed, ",\n");
  std::vector<std::string> changes;
  for (const ClientStateChange& change : summary.state_changes) {
    changes.push_back(absl::StrCat("{\"after_frames\": ", change.after_frames,
                                   ", \"state\": ", JsonString(change.state), "}"));
  }
  absl::StrAppend(&json, "  \"state_changes\": [", absl::StrJoin(changes, ", "), "],\n");
  std::vector<std::string> times;
  for (const double ns : summary.slice_time_of_flight_ns) times.push_back(JsonNumber(ns));
  absl::StrAppend(&json, "  \"slice_time_of_flight_ns\": [", absl::StrJoin(times, ", "), "],\n");
  absl::StrAppend(&json, "  \"colour_map\": \"inferno (9-point approximation), NaN = grey ",
                  kNoValueGrey.r, "\",\n");
  absl::StrAppend(&json, "  \"slice_colour_scale\": ",
                  summary.slice_scale > 0.0f ? JsonNumber(summary.slice_scale) : "null", ",\n");
  absl::StrAppend(&json, "  \"cumulative_colour_scale\": ",
                  summary.cumulative_scale > 0.0f ? JsonNumber(summary.cumulative_scale) : "null",
                  ",\n");
  absl::StrAppend(&json, "  \"colour_scale_percentile\": ", JsonNumber(kColourScalePercentile),
                  ",\n");
  if (summary.moment_depth) {
    const ClientSummary::MomentDepth& m = *summary.moment_depth;
    absl::StrAppend(&json, "  \"moment_depth\": {\"bits\": ", m.bits,
                    ", \"near_m\": ", JsonNumber(m.near_m), ", \"far_m\": ", JsonNumber(m.far_m),
                    ", \"sigma_px\": ", JsonNumber(m.sigma_px),
                    ", \"from_returns\": ", m.from_returns ? "true" : "false",
                    ", \"empty_pixels\": ", m.empty_pixels,
                    ", \"virtual_plane_m\": ", JsonNumber(m.virtual_plane_m),
                    ", \"occluded_share\": ", JsonNumber(m.occluded_share), "},\n");
  }
  absl::StrAppend(&json, "  \"files\": ", JsonStrings(summary.files), ",\n");
  absl::StrAppend(&json, "  \"interrupted\": ", summary.interrupted ? "true" : "false", ",\n");
  absl::StrAppend(&json, "  \"stream_error\": ",
                  summary.stream_error.empty() ? "null" : JsonString(summary.stream_error), "\n");
  json += "}\n";
  return json;
}

std::string FormatClientSummary(const ClientSummary& summary) {
  std::string text = absl::StrFormat(
      "%d frames from transientd at %s (%s, %dx%d) in %.2f s: %.1f Hz, %d missed", summary.frames,
      summary.address, summary.source_uri, summary.camera_width, summary.camera_height,
      summary.seconds, summary.rate_hz, summary.frames_missed);
  if (summary.corrupt_frames > 0) {
    absl::StrAppendFormat(&text, ", %d corrupt (dropped)", summary.corrupt_frames);
  }
  if (summary.state_announcements > 0) {
    absl::StrAppendFormat(&text, ", %d state announcements", summary.state_announcements);
  }
  absl::StrAppendFormat(&text, "\nlatency: p50 %.1f ms, p90 %.1f ms, p99 %.1f ms, max %.1f ms",
                        summary.latency.p50_ms, summary.latency.p90_ms, summary.latency.p99_ms,
                        summary.latency.max_ms);
  if (summary.moment_depth) {
    const ClientSummary::MomentDepth& m = *summary.moment_depth;
    absl::StrAppendFormat(&text,
                          "\nmoment depth map: %d bits, %.3g..%.3g m, sigma %.3g px%s; a virtual "
                          "plane at %.3g m is %.1f%% hidden by the scene",
                          m.bits, m.near_m, m.far_m, m.sigma_px,
                          m.from_returns ? ", from Pisarenko returns" : "", m.virtual_plane_m,
                          100.0 * m.occluded_share);
  }
  absl::StrAppendFormat(&text, "\nwrote %d files to %s", summary.files.size(),
                        summary.output_dir);
  return text;
}

}  // namespace transient::tools

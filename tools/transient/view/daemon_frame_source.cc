// Receives transientd frames (StreamFrames) and turns their images into TransientFrames.
#include "tools/transient/view/daemon_frame_source.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "transient/client/client.h"
#include "transient/client/decoded_image.h"
#include "transient/client/frame_stream.h"
#include "transient/formats/reconstruction_reader.h"
#include "transient/v1/transient.pb.h"
#include "transient/wire/product_registry.h"
#include "transient/reconstruct/status_context.h"

namespace transient::tools {
namespace {

using ::transient::client::DecodedImage;

// The products asked of the daemon and the planes of a TransientFrame each one fills.
struct WireProduct {
  v1::Product product;
  std::vector<Product> planes;
};

const std::vector<WireProduct>& WireProducts() {
  static const std::vector<WireProduct>* const products = new std::vector<WireProduct>{
      {v1::RANGE, {Product::kRange}},
      {v1::C0, {Product::kZerothMoment}},
      {v1::FLAGS, {Product::kFlags}},
      {v1::SLICES, {Product::kDensity}},
      {v1::CUMULATIVE, {Product::kCumulative}},
      {v1::DIRECT_INDIRECT, {Product::kPisarenkoDirect, Product::kPisarenkoIndirect}},
  };
  return *products;
}

const char* NameOf(v1::Product product) { return wire::FindProduct(product)->name; }

bool Has(ProductSet set, Product product) { return set[static_cast<int>(product)]; }

// The float planes of a TransientFrame that a daemon fills (flags are bytes, apart).
std::vector<float>* FloatPlanes(TransientFrame* frame, Product product) {
  switch (product) {
    case Product::kRange:
      return &frame->range_m;
    case Product::kZerothMoment:
      return &frame->c0;
    case Product::kDensity:
      return &frame->density;
    case Product::kCumulative:
      return &frame->cumulative;
    case Product::kPisarenkoDirect:
      return &frame->pisarenko_direct;
    case Product::kPisarenkoIndirect:
      return &frame->pisarenko_indirect;
    default:
      return nullptr;
  }
}

// Copies the image's values into plane image.index of `planes` (bins planes), once per plane.
absl::Status PutPlane(const DecodedImage& image, int bins, int64_t pixels,
                      std::vector<float>* planes, std::vector<bool>* seen) {
  const int plane = image.index;
  if (plane < 0 || plane >= bins || (*seen)[plane]) {
    return absl::DataLossError(absl::StrCat("image '", image.name, "': expected ",
                                            wire::Image(image.kind).stem, "/N once for each N in 0..",
                                            bins - 1));
  }
  (*seen)[plane] = true;
  planes->resize(static_cast<size_t>(bins * pixels));
  std::copy(image.values.begin(), image.values.end(), planes->begin() + plane * pixels);
  return absl::OkStatus();
}

// The planes of `wanted` from the decoded images of frame `sequence`; DataLoss naming what does
// not fit.
absl::Status FillFrame(const std::vector<DecodedImage>& images, uint64_t sequence,
                       ProductSet wanted, TransientFrame* frame) {
  const int64_t pixels = frame->geometry.pixel_count();
  const int bins = frame->bins();
  std::vector<bool> density_seen(bins, false), cumulative_seen(bins, false);
  for (const DecodedImage& image : images) {
    if (image.geometry != frame->geometry) {
      return absl::DataLossError(absl::StrCat(
          "image '", image.name, "' of frame ", sequence, " is ", image.geometry.width, "x",
          image.geometry.height, " px, expected the sensor's ", frame->geometry.width, "x",
          frame->geometry.height, " px"));
    }
    absl::Status status;
    switch (image.kind) {
      case wire::ImageKind::kRange:
        frame->range_m = image.values;
        break;
      case wire::ImageKind::kC0:
        frame->c0 = image.values;
        break;
      case wire::ImageKind::kFlags:
        frame->flags.resize(static_cast<size_t>(pixels));
        for (int64_t p = 0; p < pixels; ++p) {
          const float value = image.values[p];
          if (!(value >= 0.0f && value <= 255.0f && value == std::floor(value))) {
            return absl::DataLossError(absl::StrCat("image 'flags' of frame ", sequence,
                                                    ": value ", value, " is not a byte"));
          }
          frame->flags[p] = static_cast<uint8_t>(value);
        }
        break;
      case wire::ImageKind::kSlice:
        status = PutPlane(image, bins, pixels, &frame->density, &density_seen);
        break;
      case wire::ImageKind::kCumulative:
        status = PutPlane(image, bins, pixels, &frame->cumulative, &cumulative_seen);
        break;
      case wire::ImageKind::kDirect:
        frame->pisarenko_direct = image.values;
        break;
      case wire::ImageKind::kIndirect:
        frame->pisarenko_indirect = image.values;
        break;
      default:
        break;  // not asked for: ignored
    }
    if (!status.ok()) return status;
  }
  const bool all_density = std::all_of(density_seen.begin(), density_seen.end(), std::identity());
  const bool all_cumulative =
      std::all_of(cumulative_seen.begin(), cumulative_seen.end(), std::identity());
  std::vector<std::string> missing;
  for (const WireProduct& product : WireProducts()) {
    for (Product plane : product.planes) {
      if (!Has(wanted, plane)) continue;
      const bool present = plane == Product::kFlags     ? !frame->flags.empty()
                           : plane == Product::kDensity ? !frame->density.empty() && all_density
                           : plane == Product::kCumulative
                               ? !frame->cumulative.empty() && all_cumulative
                               : !FloatPlanes(frame, plane)->empty();
      if (!present) {
        missing.push_back(NameOf(product.product));
        break;  // direct_indirect once, not once per plane
      }
    }
  }
  if (!missing.empty()) {
    return absl::DataLossError(
        absl::StrCat("frame ", sequence, " lacks ", absl::StrJoin(missing, ", ")));
  }
  return absl::OkStatus();
}

}  // namespace

bool IsDaemonInput(absl::string_view input) { return absl::StartsWith(input, kDaemonInputPrefix); }

absl::Status DaemonSourceOptions::Validate() const {
  if (address.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("input '", kDaemonInputPrefix, "': expected ",
                                                   kDaemonInputPrefix, "HOST:PORT or ",
                                                   kDaemonInputPrefix, "unix:PATH"));
  }
  if (frames < 1 || frames > kMaxDaemonFrames) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--frames = ", frames, ": a daemon input takes the number of frames to receive, 1..",
        kMaxDaemonFrames));
  }
  if (bins < 1 || bins > wire::kMaxSlices) {
    return absl::InvalidArgumentError(absl::StrCat("--bins = ", bins, ": transientd sends 1..",
                                                   wire::kMaxSlices, " slices a frame"));
  }
  if (!(connect_timeout_s > 0.0) || !std::isfinite(connect_timeout_s)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--connect-timeout = ", connect_timeout_s, ": expected > 0 seconds"));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<DaemonFrameSource>> DaemonFrameSource::Receive(
    const DaemonSourceOptions& options, const std::atomic<bool>* cancel) {
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  const std::string& address = options.address;
  absl::StatusOr<client::Client> daemon = client::Client::Connect(
      {.address = address,
       .security = options.security,
       .timeout_s = options.connect_timeout_s,
       .cancel = cancel});
  if (!daemon.ok()) return daemon.status();
  absl::StatusOr<v1::Info> info = daemon->GetInfo();
  if (!info.ok()) return info.status();
  absl::StatusOr<v1::Config> config = daemon->GetConfig();
  if (!config.ok()) return config.status();

  std::unique_ptr<DaemonFrameSource> source(new DaemonFrameSource());
  source->name_ = absl::StrCat(kDaemonInputPrefix, address);
  source->source_uri_ = info->source_uri();
  const v1::CameraInfo& camera = info->camera();
  const double f = info->schedule().base_frequency_hz();
  if (camera.width() == 0 || camera.height() == 0 || camera.width() > client::kMaxImageSide ||
      camera.height() > client::kMaxImageSide || !(f > 0.0) || !std::isfinite(f)) {
    return absl::DataLossError(absl::StrCat(
        "GetInfo from transientd at ", address, ": a ", camera.width(), "x", camera.height(),
        " px camera at base frequency ", f, " Hz; expected a sensor and a frequency > 0"));
  }
  source->geometry_ = {static_cast<int>(camera.width()), static_cast<int>(camera.height())};
  source->base_frequency_hz_ = f;
  source->order_ = static_cast<int>(info->schedule().order());
  if (config->has_threshold()) source->threshold_ = config->threshold();
  const PinholeIntrinsics intrinsics{
      .fx = camera.fx(), .fy = camera.fy(), .cx = camera.cx(), .cy = camera.cy()};
  if (intrinsics.Validate().ok()) source->intrinsics_ = intrinsics;

  // What to ask for: every product of WireProducts() that the daemon offers (an empty list
  // from an older daemon: all of them).
  v1::StreamRequest request;
  std::vector<std::string> not_offered;
  for (const WireProduct& product : WireProducts()) {
    const bool offered =
        info->products_size() == 0 || std::find(info->products().begin(), info->products().end(),
                                                product.product) != info->products().end();
    if (!offered) {
      not_offered.push_back(NameOf(product.product));
      continue;
    }
    request.add_products(product.product);
    for (Product plane : product.planes) source->available_.set(static_cast<int>(plane));
  }
  if (!not_offered.empty()) {
    source->notes_.push_back(absl::StrCat("transientd at ", address, " does not offer ",
                                          absl::StrJoin(not_offered, ", ")));
  }
  const bool slices =
      Has(source->available_, Product::kDensity) || Has(source->available_, Product::kCumulative);
  if (slices) {
    for (int n = 0; n < options.bins; ++n) {
      source->phases_.push_back(2.0 * std::numbers::pi * n / options.bins);
    }
  }
  const int64_t pixels = source->geometry_.pixel_count();
  const int64_t bytes_per_frame = pixels * (4 * (4 + 2 * int64_t{options.bins}) + 1);
  if (options.frames * bytes_per_frame > kMaxDaemonFrameBytes) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--frames %d --bins %d of the %dx%d px sensor of transientd at %s need %d MiB in "
        "memory; at most %d MiB: ask for fewer frames or bins",
        options.frames, options.bins, source->geometry_.width, source->geometry_.height, address,
        options.frames * bytes_per_frame >> 20, kMaxDaemonFrameBytes >> 20));
  }
  request.set_encoding(v1::FLOAT32);  // the density as the daemon computed it
  request.mutable_slices()->set_bins(static_cast<uint32_t>(options.bins));

  TransientFrame blank;
  blank.geometry = source->geometry_;
  blank.order = source->order_;
  blank.base_frequency_hz = f;
  blank.threshold = source->threshold_;
  blank.phases = source->phases_;

  // Dropped here (wrong size, a product missing), or by the stream (an image did not decode).
  int64_t dropped = 0;
  absl::Status last_dropped;
  std::unique_ptr<client::FrameStream> stream = daemon->StreamFrames(request, {.cancel = cancel});
  const auto unusable = [&] { return dropped + stream->counts().corrupt; };
  client::StreamFrame received;
  while (source->frames() < options.frames && unusable() <= options.frames &&
         stream->Next(&received)) {
    if (received.kind == client::StreamFrame::Kind::kAnnouncement) continue;
    if (received.kind == client::StreamFrame::Kind::kCorrupt) {
      last_dropped = received.corruption;
      continue;
    }
    TransientFrame frame = blank;
    frame.index = source->frames();
    if (absl::Status status =
            FillFrame(received.images, received.sequence, source->available_, &frame);
        !status.ok()) {
      ++dropped;
      last_dropped = status;
      continue;
    }
    source->frames_.push_back(std::move(frame));
    source->sequences_.push_back(received.sequence);
  }
  // OK when we ended it (enough frames, too many unusable), Cancelled when interrupted.
  const absl::Status stream_status = stream->Finish();
  const bool interrupted = stream_status.code() == absl::StatusCode::kCancelled &&
                           cancel != nullptr && cancel->load();
  dropped = unusable();
  if (interrupted) {
    return absl::CancelledError(absl::StrCat(
        "interrupted while receiving frames from transientd at ", address, "; nothing written"));
  }
  if (dropped > options.frames) {
    return WithContext(
        absl::StrCat("transientd at ", address, ": ", dropped, " unusable frames, the last"),
        last_dropped);
  }
  if (dropped > 0) {
    source->notes_.push_back(absl::StrCat(dropped, " frame", dropped == 1 ? "" : "s",
                                          " from transientd dropped: ", last_dropped.message()));
  }
  const bool ended_early = source->frames() < options.frames;
  if (ended_early) {
    const absl::Status ended =
        stream_status.ok() ? absl::OutOfRangeError("the stream ended") : stream_status;
    // A replay that reached its end (OutOfRange) still leaves the frames it sent; anything
    // else, or nothing received, is an error.
    if (source->frames_.empty() || ended.code() != absl::StatusCode::kOutOfRange) {
      return WithContext(absl::StrCat("stream from transientd at ", address, " ended after ",
                                   source->frames(), " of ", options.frames, " frames"),
                      ended);
    }
    source->notes_.push_back(absl::StrCat("transientd sent ", source->frames(), " of the ",
                                          options.frames, " frames asked for: ", ended.message()));
  }
  return source;
}

absl::Status DaemonFrameSource::ReadFrame(int64_t frame, ProductSet wanted,
                                          TransientFrame* out) const {
  if (frame < 0 || frame >= frames()) {
    return absl::OutOfRangeError(
        absl::StrCat(name_, ": frame ", frame, " of ", frames(), " received"));
  }
  const ProductSet missing = wanted & ~available_;
  if (missing.any()) {
    std::vector<std::string> names;
    for (int p = 0; p < kProductCount; ++p) {
      if (missing[p]) names.push_back(ProductPath(static_cast<Product>(p)));
    }
    return absl::NotFoundError(
        absl::StrCat(name_, ": transientd sends no ", absl::StrJoin(names, ", ")));
  }
  const TransientFrame& stored = frames_[frame];
  *out = TransientFrame{.geometry = stored.geometry,
                        .order = stored.order,
                        .base_frequency_hz = stored.base_frequency_hz,
                        .index = stored.index,
                        .threshold = stored.threshold,
                        .phases = stored.phases};
  if (Has(wanted, Product::kFlags)) out->flags = stored.flags;
  for (int p = 0; p < kProductCount; ++p) {
    if (!wanted[p]) continue;
    const Product product = static_cast<Product>(p);
    if (std::vector<float>* plane = FloatPlanes(out, product); plane != nullptr) {
      *plane = *FloatPlanes(const_cast<TransientFrame*>(&stored), product);
    }
  }
  return absl::OkStatus();
}

}  // namespace transient::tools

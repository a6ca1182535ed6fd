#include "transient/service/stream_plan.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "transient/wire/product_registry.h"

namespace transient::service {
namespace {

using ::transient::wire::CheckEncoding;
using ::transient::wire::EncodeBytePlane;
using ::transient::wire::EncodeFloatPlane;
using ::transient::wire::EncodeMomentDepth;
using ::transient::wire::ImageKind;
using ::transient::wire::PixelRect;
using ::transient::wire::ProductSpec;
using ::transient::wire::ResolveRoi;

// What the daemon refuses and what clients are told it refuses are one number.
static_assert(wire::kMaxSlices == kMaxSlices);


// The enum names of the products the registry knows: RANGE, DEPTH, ...
std::string ValidProductNames() {
  std::vector<std::string> names;
  for (const wire::ProductSpec& spec : wire::Products()) {
    names.push_back(v1::Product_Name(spec.product));
  }
  return absl::StrJoin(names, ", ");
}


// What a depth camera serves, for its refusals.
std::string DepthCameraServes(const ScheduleOptions& schedule) {
  return absl::StrCat("This camera serves RANGE, DEPTH, ",
                      schedule.depth_amplitude ? "AMPLITUDE, " : "",
                      "FLAGS and MOMENT_DEPTH of its depth");
}


// Names an encoded image of `kind` (index: its slice or harmonic) as the registry says.
void Label(ImageKind kind, int index, v1::Image* image) {
  image->set_name(wire::ImageName(kind, index));
  image->set_product(wire::Image(kind).product);
  image->set_unit(wire::WireUnit(kind, image->encoding()));
}

// Adds one float plane as an image; false when the frame lacks it (asked for after the frame's
// products were chosen).
absl::StatusOr<bool> AddFloat(const StreamPlan& plan, const FrameProducts& products,
                              std::span<const float> plane, ImageKind kind, v1::Frame* frame,
                              int index = 0, double time_ns = 0.0) {
  if (plane.size() != static_cast<size_t>(products.geometry.pixel_count())) return false;
  v1::Image* image = frame->add_images();
  if (absl::Status status = EncodeFloatPlane(plane, products.geometry, plan.rect, plan.encoding,
                                             plan.compression, image);
      !status.ok()) {
    return status;
  }
  Label(kind, index, image);
  image->set_time_of_flight_ns(time_ns);  // 0 (proto3: not sent) for all but slices
  return true;
}

}  // namespace

v1::SourceState ToProto(SourceState state) {
  switch (state) {
    case SourceState::kStreaming: return v1::STREAMING;
    case SourceState::kReconnecting: return v1::RECONNECTING;
    case SourceState::kEnded: return v1::ENDED;
  }
  return v1::SOURCE_STATE_UNSPECIFIED;
}

google::protobuf::Timestamp ToTimestamp(absl::Time t) {
  google::protobuf::Timestamp out;
  const int64_t nanos = absl::ToUnixNanos(t);
  out.set_seconds(nanos / 1000000000);
  out.set_nanos(static_cast<int32_t>(nanos % 1000000000));
  return out;
}

// FailedPrecondition for a product the schedule cannot serve (ProductSpec::needs): the moment
// reconstruction's on a camera's harmonic set, naming the missing harmonics, and the
// unwrapping's confidence on a schedule with every harmonic. A depth camera
// (SamplingScheme::kDepth) serves the products that need nothing (Needs::kAny), AMPLITUDE only
// when it delivers an amplitude frame.
absl::Status CheckScheduleServes(std::span<const v1::Product> products, bool moment_depth_of_returns,
                                 const ScheduleOptions& schedule) {
  const bool all = schedule.HasAllHarmonics();
  for (v1::Product product : products) {
    const wire::ProductSpec& spec = *wire::FindProduct(product);
    ProductSpec::Needs needs = spec.needs;
    if (product == v1::MOMENT_DEPTH && moment_depth_of_returns) {
      needs = ProductSpec::Needs::kAllHarmonics;  // of the Pisarenko returns
    }
    if (schedule.DeliversDepth()) {
      if (needs != ProductSpec::Needs::kAny) {
        const std::string what =
            needs == ProductSpec::Needs::kHarmonicSet
                ? "the confidence of phase unwrapping"
                : (product == v1::MOMENT_DEPTH ? "a moment depth map of the Pisarenko returns"
                                               : "the moment reconstruction");
        return absl::FailedPreconditionError(
            absl::StrCat(v1::Product_Name(product), ": ", schedule.MissingHarmonicsText(what),
                         ". ", DepthCameraServes(schedule)));
      }
      if (product == v1::AMPLITUDE && !schedule.depth_amplitude) {
        return absl::FailedPreconditionError(absl::StrCat(
            "AMPLITUDE: the source delivers depth without an amplitude image. ",
            DepthCameraServes(schedule)));
      }
      continue;
    }
    if (needs == ProductSpec::Needs::kAllHarmonics && !all) {
      return absl::FailedPreconditionError(absl::StrCat(
          v1::Product_Name(product), ": ",
          schedule.MissingHarmonicsText("the moment reconstruction"),
          ". This camera serves RANGE, DEPTH, AMPLITUDE, FLAGS, CONFIDENCE and MOMENT_DEPTH of "
          "the depth, by phase unwrapping; transient video needs a programmable camera"));
    }
    if (needs == ProductSpec::Needs::kHarmonicSet && all) {
      return absl::FailedPreconditionError(absl::StrCat(
          v1::Product_Name(product),
          ": the confidence of phase unwrapping is served for a camera's harmonic set (e.g. the "
          "Kinect v2's); this schedule measures every harmonic 1..",
          schedule.order, ", whose range comes from the moment reconstruction"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<StreamPlan> PlanStream(const v1::StreamRequest& r, const Pipeline& pipeline) {
  StreamPlan plan;
  if (r.products_size() == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("products: expected at least one of ", ValidProductNames()));
  }
  for (int p : r.products()) {
    if (wire::FindProduct(static_cast<v1::Product>(p)) == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat("products: unknown product ", p,
                                                     "; expected ", ValidProductNames()));
    }
    const auto product = static_cast<v1::Product>(p);
    if (!plan.request.products.Has(product)) plan.products.push_back(product);
    plan.request.products.Add(product);
  }
  if (absl::Status status = CheckScheduleServes(plan.products, r.moment_depth().from_returns(),
                                                pipeline.schedule().options());
      !status.ok()) {
    return status;
  }
  const ImageGeometry sensor = pipeline.camera().geometry;
  absl::StatusOr<PixelRect> rect = ResolveRoi(r.roi(), sensor);
  if (!rect.ok()) return rect.status();
  plan.rect = *rect;
  if (!v1::Encoding_IsValid(r.encoding())) {
    return absl::InvalidArgumentError(absl::StrCat("encoding: unknown encoding ", r.encoding()));
  }
  plan.encoding = r.encoding() == v1::ENCODING_UNSPECIFIED ? v1::FLOAT32 : r.encoding();
  for (v1::Product product : plan.products) {
    if (absl::Status status = CheckEncoding(product, plan.encoding); !status.ok()) return status;
  }
  if (!v1::Compression_IsValid(r.compression())) {
    return absl::InvalidArgumentError(
        absl::StrCat("compression: unknown compression ", r.compression()));
  }
  plan.compression = r.compression();
  if (!std::isfinite(r.max_rate_hz()) || r.max_rate_hz() < 0.0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "max_rate_hz = ", r.max_rate_hz(), ": expected a finite rate >= 0 (0 = every frame)"));
  }
  if (r.max_rate_hz() > 0.0) plan.min_interval = absl::Seconds(1.0 / r.max_rate_hz());
  if (r.queue_frames() > static_cast<uint32_t>(kMaxQueueFrames)) {
    return absl::InvalidArgumentError(
        absl::StrCat("queue_frames = ", r.queue_frames(), ": expected 0..", kMaxQueueFrames));
  }
  if (r.queue_frames() > 0) plan.queue_frames = static_cast<int>(r.queue_frames());
  if (plan.request.products.Has(v1::SLICES) || plan.request.products.Has(v1::CUMULATIVE)) {
    v1::SliceSpec spec = r.slices();
    if (!r.has_slices()) spec.set_bins(kDefaultSlices);
    absl::StatusOr<std::vector<double>> phases =
        ResolveSlicePhases(spec, pipeline.schedule().options().base_frequency_hz, sensor);
    if (!phases.ok()) return phases.status();
    plan.request.slice_phases = *std::move(phases);
  }
  if (plan.request.products.Has(v1::MOMENT_DEPTH)) {
    absl::StatusOr<MomentDepthSpec> spec = ResolveMomentDepthSpec(
        r.moment_depth(), sensor, pipeline.schedule().options().UnambiguousRangeM());
    if (!spec.ok()) return spec.status();
    plan.request.moment_depth = *spec;
  }
  // A client that stops reading holds its queue: bound what that can keep alive.
  int64_t planes = 0;
  for (v1::Product product : plan.products) {
    planes += wire::PlanesPerFrame(product, pipeline.schedule().order(),
                                   static_cast<int>(plan.request.slice_phases.size()));
  }
  const int64_t frame_bytes = planes * sensor.pixel_count() * 4;
  if (frame_bytes * plan.queue_frames > kMaxQueueBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "queue_frames = ", plan.queue_frames, ": frames of these products take ",
        frame_bytes >> 10, " KiB each; at most ", kMaxQueueBytes >> 20,
        " MiB may wait for one client (queue_frames <= ",
        std::max<int64_t>(1, kMaxQueueBytes / std::max<int64_t>(1, frame_bytes)), ")"));
  }
  return plan;
}


// What EncodeProducts's result depends on besides the frame: streams whose plans have the same
// key share one encoding of each frame (PublishedFrame::encoded). Phases as hexadecimal floats:
// exact.
std::string EncodingKey(const StreamPlan& plan) {
  std::string key;
  for (v1::Product p : plan.products) absl::StrAppend(&key, static_cast<int>(p), ",");
  absl::StrAppend(&key, "|", plan.rect.x, ",", plan.rect.y, ",", plan.rect.width, ",",
                  plan.rect.height, "|", static_cast<int>(plan.encoding), "|",
                  static_cast<int>(plan.compression), "|");
  for (double phase : plan.request.slice_phases) absl::StrAppend(&key, absl::StrFormat("%a,", phase));
  const MomentDepthSpec& m = plan.request.moment_depth;
  absl::StrAppend(&key, "|",
                  absl::StrFormat("%a,%a,%a,%d,%d", m.near_m, m.far_m, m.sigma_px,
                                  static_cast<int>(m.format), m.from_returns ? 1 : 0));
  return key;
}

// Fills `frame` with the planned products of `products`. false when one is missing.
absl::StatusOr<bool> EncodeProducts(const StreamPlan& plan, const FrameProducts& products,
                                    v1::Frame* frame) {
  const size_t pixels = static_cast<size_t>(products.geometry.pixel_count());
  for (v1::Product product : plan.products) {
    absl::StatusOr<bool> added = true;
    switch (product) {
      case v1::RANGE:
        added = AddFloat(plan, products, products.range_m, ImageKind::kRange, frame);
        break;
      case v1::DEPTH:
        added = AddFloat(plan, products, products.depth_m, ImageKind::kDepth, frame);
        break;
      case v1::AMPLITUDE:
        added = AddFloat(plan, products, products.amplitude, ImageKind::kAmplitude, frame);
        break;
      case v1::C0:
        added = AddFloat(plan, products, products.c0, ImageKind::kC0, frame);
        break;
      case v1::FLAGS: {
        v1::Image* image = frame->add_images();
        if (absl::Status status = EncodeBytePlane(products.flags, products.geometry, plan.rect,
                                                  plan.compression, image);
            !status.ok()) {
          return status;
        }
        Label(ImageKind::kFlags, 0, image);
        break;
      }
      case v1::MOMENT_STATE: {
        const SolvedImage& s = *products.solved;
        std::vector<float> plane(pixels);
        auto add_plane = [&](const std::vector<double>& source, int j,
                             ImageKind kind) -> absl::StatusOr<bool> {
          for (size_t p = 0; p < pixels; ++p) {
            plane[p] = static_cast<float>(source[j * pixels + p]);
          }
          return AddFloat(plan, products, plane, kind, frame, j);
        };
        for (int j = 0; j <= s.order && added.ok(); ++j) {
          added = add_plane(s.c_real, j, ImageKind::kCReal);
          if (added.ok() && j > 0) added = add_plane(s.c_imag, j, ImageKind::kCImag);
          if (added.ok()) added = add_plane(s.q_real, j, ImageKind::kQReal);
          if (added.ok()) added = add_plane(s.q_imag, j, ImageKind::kQImag);
        }
        break;
      }
      case v1::SLICES:
      case v1::CUMULATIVE: {
        auto it = products.slices.find(plan.request.slice_phases);
        if (it == products.slices.end()) return false;
        const std::vector<float>& planes =
            product == v1::SLICES ? it->second.density : it->second.cumulative;
        const std::vector<double>& phases = plan.request.slice_phases;
        if (planes.size() != phases.size() * pixels) return false;
        for (size_t n = 0; n < phases.size() && added.ok() && *added; ++n) {
          added = AddFloat(plan, products,
                           std::span<const float>(planes).subspan(n * pixels, pixels),
                           product == v1::SLICES ? ImageKind::kSlice : ImageKind::kCumulative,
                           frame, static_cast<int>(n),
                           PhaseToTimeOfFlightNs(phases[n], products.base_frequency_hz));
        }
        break;
      }
      case v1::DIRECT_INDIRECT:
        added = AddFloat(plan, products, products.direct, ImageKind::kDirect, frame);
        if (added.ok() && *added) {
          added = AddFloat(plan, products, products.indirect, ImageKind::kIndirect, frame);
        }
        break;
      case v1::CONFIDENCE:
        added = AddFloat(plan, products, products.confidence, ImageKind::kConfidence, frame);
        break;
      case v1::MOMENT_DEPTH: {
        auto it = products.moment_depth.find(plan.request.moment_depth);
        if (it == products.moment_depth.end()) return false;
        v1::Image* image = frame->add_images();
        if (absl::Status status =
                EncodeMomentDepth(*it->second, plan.request.moment_depth.from_returns, plan.rect,
                                  plan.compression, image);
            !status.ok()) {
          return status;
        }
        Label(ImageKind::kMomentDepth, 0, image);
        break;
      }
      default:
        return absl::InternalError(absl::StrCat("unplanned product ", product));
    }
    if (!added.ok()) return added.status();
    if (!*added) return false;
  }
  return true;
}

absl::StatusOr<std::optional<v1::Frame>> FrameForStream(const StreamPlan& plan,
                                                        const std::string& key,
                                                        const PublishedFrame& published,
                                                        uint64_t missed) {
  // Encoded once per plan: the first stream with this plan encodes, the others copy.
  std::shared_ptr<const v1::Frame> images = published.encoded.Find(key);
  if (images == nullptr) {
    auto encoded = std::make_shared<v1::Frame>();
    absl::StatusOr<bool> complete = EncodeProducts(plan, *published.products, encoded.get());
    if (!complete.ok()) return complete.status();
    if (!*complete) return std::nullopt;
    images = published.encoded.Insert(key, std::move(encoded));
  }
  v1::Frame frame;
  frame.set_state(ToProto(published.state));
  *frame.mutable_publish_time() = ToTimestamp(published.publish);
  *frame.mutable_images() = images->images();
  frame.set_sequence(published.sequence);
  frame.set_capture_time_s(published.capture_time_s);
  frame.set_missed(missed);
  frame.set_latency_s(absl::ToDoubleSeconds(published.publish - published.arrival));
  v1::Roi* roi = frame.mutable_roi();
  roi->set_x(plan.rect.x);
  roi->set_y(plan.rect.y);
  roi->set_width(plan.rect.width);
  roi->set_height(plan.rect.height);
  return frame;
}

}  // namespace transient::service

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

}  // namespace

v1::SourceState ToProto(SourceState state) {
  switch (state) {
    case SourceState::kStreaming:
      return v1::STREAMING;
    case SourceState::kReconnecting:
      return v1::RECONNECTING;
    case SourceState::kEnded:
      return v1::ENDED;
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
absl::Status CheckScheduleServes(std::span<const v1::Product> products,
                                 bool moment_depth_of_returns, const ScheduleOptions& schedule) {
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
        return absl::FailedPreconditionError(absl::StrCat(v1::Product_Name(product), ": ",
                                                          schedule.MissingHarmonicsText(what), ". ",
                                                          DepthCameraServes(schedule)));
      }
      if (product == v1::AMPLITUDE && !schedule.depth_amplitude) {
        return absl::FailedPreconditionError(
            absl::StrCat("AMPLITUDE: the source delivers depth without an amplitude image. ",
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
      return absl::InvalidArgumentError(
          absl::StrCat("products: unknown product ", p, "; expected ", ValidProductNames()));
    }
    const auto product = static_cast<v1::Product>(p);
    if (!plan.request.products.Has(product)) plan.images.products.push_back(product);
    plan.request.products.Add(product);
  }
  if (absl::Status status = CheckScheduleServes(
          plan.images.products, r.moment_depth().from_returns(), pipeline.schedule().options());
      !status.ok()) {
    return status;
  }
  const ImageGeometry sensor = pipeline.camera().geometry;
  absl::StatusOr<PixelRect> rect = ResolveRoi(r.roi(), sensor);
  if (!rect.ok()) return rect.status();
  plan.images.rect = *rect;
  if (!v1::Encoding_IsValid(r.encoding())) {
    return absl::InvalidArgumentError(absl::StrCat("encoding: unknown encoding ", r.encoding()));
  }
  plan.images.encoding = r.encoding() == v1::ENCODING_UNSPECIFIED ? v1::FLOAT32 : r.encoding();
  for (v1::Product product : plan.images.products) {
    if (absl::Status status = CheckEncoding(product, plan.images.encoding); !status.ok())
      return status;
  }
  if (!v1::Compression_IsValid(r.compression())) {
    return absl::InvalidArgumentError(
        absl::StrCat("compression: unknown compression ", r.compression()));
  }
  plan.images.compression = r.compression();
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
    plan.images.slice_phases = plan.request.slice_phases;
  }
  if (plan.request.products.Has(v1::MOMENT_DEPTH)) {
    absl::StatusOr<MomentDepthSpec> spec = ResolveMomentDepthSpec(
        r.moment_depth(), sensor, pipeline.schedule().options().UnambiguousRangeM());
    if (!spec.ok()) return spec.status();
    plan.request.moment_depth = *spec;
    plan.images.moment_depth = *spec;
  }
  // A client that stops reading holds its queue: bound what that can keep alive.
  int64_t planes = 0;
  for (v1::Product product : plan.images.products) {
    planes += wire::PlanesPerFrame(product, pipeline.schedule().order(),
                                   static_cast<int>(plan.request.slice_phases.size()));
  }
  const int64_t frame_bytes = planes * sensor.pixel_count() * 4;
  if (frame_bytes * plan.queue_frames > kMaxQueueBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "queue_frames = ", plan.queue_frames, ": frames of these products take ", frame_bytes >> 10,
        " KiB each; at most ", kMaxQueueBytes >> 20,
        " MiB may wait for one client (queue_frames <= ",
        std::max<int64_t>(1, kMaxQueueBytes / std::max<int64_t>(1, frame_bytes)), ")"));
  }
  return plan;
}

StreamMessage::StreamMessage(v1::Frame fields, std::shared_ptr<const v1::Frame> images)
    : images_(std::move(images)), frame_(std::move(fields)) {
  frame_.clear_images();
  // Lent, not owned: the field holds the shared images' addresses until the destructor takes
  // them back out. Nothing writes through them (frame() is const).
  for (const v1::Image& image : images_->images()) {
    frame_.mutable_images()->AddAllocated(const_cast<v1::Image*>(&image));
  }
}

StreamMessage::~StreamMessage() {
  google::protobuf::RepeatedPtrField<v1::Image>* lent = frame_.mutable_images();
  while (!lent->empty()) {
    [[maybe_unused]] v1::Image* shared = lent->ReleaseLast();  // the encoding's, not ours
  }
}

absl::StatusOr<std::unique_ptr<StreamMessage>> MessageForStream(const StreamPlan& plan,
                                                                const std::string& key,
                                                                const PublishedFrame& published,
                                                                uint64_t missed) {
  // Encoded once per plan: the first stream with this plan encodes, the others share it.
  std::shared_ptr<const v1::Frame> images = published.encoded.Find(key);
  if (images == nullptr) {
    auto encoded = std::make_shared<v1::Frame>();
    absl::StatusOr<bool> complete =
        wire::EncodeProducts(plan.images, *published.products, encoded.get());
    if (!complete.ok()) return complete.status();
    if (!*complete) return nullptr;
    images = published.encoded.Insert(key, std::move(encoded));
  }
  v1::Frame fields;
  fields.set_state(ToProto(published.state));
  *fields.mutable_publish_time() = ToTimestamp(published.publish);
  fields.set_sequence(published.sequence);
  fields.set_capture_time_s(published.capture_time_s);
  fields.set_missed(missed);
  fields.set_latency_s(absl::ToDoubleSeconds(published.publish - published.arrival));
  v1::Roi* roi = fields.mutable_roi();
  roi->set_x(plan.images.rect.x);
  roi->set_y(plan.images.rect.y);
  roi->set_width(plan.images.rect.width);
  roi->set_height(plan.images.rect.height);
  return std::make_unique<StreamMessage>(std::move(fields), std::move(images));
}

absl::StatusOr<std::optional<v1::Frame>> FrameForStream(const StreamPlan& plan,
                                                        const std::string& key,
                                                        const PublishedFrame& published,
                                                        uint64_t missed) {
  absl::StatusOr<std::unique_ptr<StreamMessage>> message =
      MessageForStream(plan, key, published, missed);
  if (!message.ok()) return message.status();
  if (*message == nullptr) return std::nullopt;
  return (*message)->frame();  // a copy that owns its images
}

}  // namespace transient::service

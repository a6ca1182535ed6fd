#include "transient/service/server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/impl/server_builder_option.h>
#include <grpcpp/impl/server_builder_plugin.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/physical_constants.h"
#include "transient/service/nats_publisher.h"
#include "transient/service/stream_plan.h"
#include "transient/v1/transient.grpc.pb.h"
#include "transient/wire/grpc_status.h"
#include "transient/wire/image_codec.h"
#include "transient/wire/product_registry.h"

namespace transient::service {
namespace {

using ::transient::wire::ToGrpcStatus;
using ::transient::wire::EncodeFloatPlane;
using ::transient::wire::PixelRect;
using ::transient::wire::ResolveRoi;
using ::transient::wire::CheckEncoding;
using ::transient::wire::EncodeBytePlane;
using ::transient::wire::EncodeMomentDepth;
using ::transient::wire::ImageKind;
using ::transient::wire::ProductSpec;

constexpr int kDefaultPixelBins = 256;
constexpr int kMaxPixelBins = 65536;
constexpr absl::Duration kPollInterval = absl::Milliseconds(100);

absl::StatusOr<ReconstructionConfig> Merge(const ReconstructionConfig& current,
                                           const v1::Config& update) {
  ReconstructionConfig c = current;
  if (update.has_range_method()) {
    switch (update.range_method()) {
      case v1::MESE: c.range_method = RangeMethod::kMese; break;
      case v1::PISARENKO: c.range_method = RangeMethod::kPisarenko; break;
      default:
        return absl::InvalidArgumentError(absl::StrCat(
            "range_method = ", update.range_method(), ": expected MESE or PISARENKO"));
    }
  }
  if (update.has_bias_epsilon()) c.bias_epsilon = update.bias_epsilon();
  if (update.has_threshold()) c.threshold = update.threshold();
  if (update.has_smoothing_sigma_px()) c.smoothing_sigma_px = update.smoothing_sigma_px();
  if (update.has_takes()) {
    if (update.takes() > 1024) {  // before the int conversion; Validate() names the range
      return absl::InvalidArgumentError(absl::StrCat("takes = ", update.takes(), ": too large"));
    }
    c.takes = static_cast<int>(update.takes());
  }
  if (update.has_video()) c.video = update.video();
  if (absl::Status status = c.Validate(); !status.ok()) return status;
  return c;
}

v1::Config ToProto(const ReconstructionConfig& c) {
  v1::Config out;
  out.set_range_method(c.range_method == RangeMethod::kMese ? v1::MESE : v1::PISARENKO);
  out.set_bias_epsilon(c.bias_epsilon);
  out.set_threshold(c.threshold);
  out.set_smoothing_sigma_px(c.smoothing_sigma_px);
  out.set_takes(static_cast<uint32_t>(c.takes));
  out.set_video(c.video);
  return out;
}

void ToProto(const RecordingStatus& r, v1::Recording* out) {
  out->set_path(r.path);
  out->set_active(r.active);
  out->set_raw_frames(r.raw_frames);
  out->set_flushed_frames(r.flushed_frames);
  out->set_error(r.error);
}

// One pixel of the solved state as a 1x1 image, for the image-level kernels.
SolvedImage SinglePixel(const SolvedImage& s, int64_t p) {
  SolvedImage one;
  one.geometry = ImageGeometry{1, 1};
  one.order = s.order;
  const int64_t pixels = s.geometry.pixel_count();
  for (int j = 0; j <= s.order; ++j) {
    one.c_real.push_back(s.c_real[j * pixels + p]);
    one.c_imag.push_back(s.c_imag[j * pixels + p]);
    one.q_real.push_back(s.q_real[j * pixels + p]);
    one.q_imag.push_back(s.q_imag[j * pixels + p]);
  }
  one.flags = {s.flags[p]};
  return one;
}

}  // namespace

class TransientServer::Service final : public v1::Transient::Service {
 public:
  Service(Pipeline* pipeline, std::string version, std::shared_ptr<const Access> access,
          const NatsPublisher* nats)
      : pipeline_(pipeline),
        version_(std::move(version)),
        access_(std::move(access)),
        nats_(nats) {}

  grpc::Status GetInfo(grpc::ServerContext* context, const v1::GetInfoRequest*,
                       v1::Info* info) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    const CameraInfo& camera = pipeline_->camera();
    v1::CameraInfo* c = info->mutable_camera();
    c->set_width(camera.geometry.width);
    c->set_height(camera.geometry.height);
    c->set_fx(camera.intrinsics.fx);
    c->set_fy(camera.intrinsics.fy);
    c->set_cx(camera.intrinsics.cx);
    c->set_cy(camera.intrinsics.cy);
    for (double d : camera.distortion) c->add_distortion(d);
    c->set_model(camera.model);
    info->set_source_uri(pipeline_->source_uri());
    const AcquisitionSchedule schedule = pipeline_->schedule();
    const ScheduleOptions& o = schedule.options();
    v1::Schedule* s = info->mutable_schedule();
    s->set_base_frequency_hz(o.base_frequency_hz);
    s->set_order(static_cast<uint32_t>(o.order));
    s->set_sampling(std::string(SamplingSchemeName(o.sampling)));
    s->set_zeroth(std::string(ZerothSchemeName(o.zeroth)));
    s->set_takes(static_cast<uint32_t>(o.takes));
    s->set_raw_frames_per_frame(static_cast<uint32_t>(schedule.raw_frames_per_frame()));
    s->set_description(schedule.Describe());
    for (int j : o.harmonics) s->add_harmonics(static_cast<uint32_t>(j));
    s->set_buckets(static_cast<uint32_t>(o.buckets));
    info->set_calibration(pipeline_->calibration_origin());
    for (int p = v1::Product_MIN + 1; p <= v1::Product_MAX; ++p) {
      if (!v1::Product_IsValid(p)) continue;
      const v1::Product product = static_cast<v1::Product>(p);
      if (CheckScheduleServes({&product, 1}, false, o).ok()) info->add_products(product);
    }
    info->set_version(version_);
    info->set_state(ToProto(pipeline_->state()));
    info->set_unambiguous_range_m(o.UnambiguousRangeM());
    v1::Access* access = info->mutable_access();
    access->set_tls(access_ != nullptr && access_->tls());
    access->set_client_certificate(access_ != nullptr && access_->client_certificate_required());
    access->set_token(access_ != nullptr && access_->token_required());
    access->set_insecure(access_ != nullptr && access_->insecure());
    return grpc::Status::OK;
  }

  grpc::Status StreamFrames(grpc::ServerContext* context, const v1::StreamRequest* request,
                            grpc::ServerWriter<v1::Frame>* writer) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    absl::StatusOr<StreamPlan> plan = PlanStream(*request, *pipeline_);
    if (!plan.ok()) return ToGrpcStatus(plan.status());
    // Subscribed first, then the state: an end announced in between is not missed.
    absl::StatusOr<std::shared_ptr<Subscription>> subscribed =
        pipeline_->Subscribe(context->peer(), plan->request, plan->queue_frames);
    if (!subscribed.ok()) return ToGrpcStatus(subscribed.status());
    const std::shared_ptr<Subscription>& subscription = *subscribed;
    absl::Status end =
        pipeline_->state() == SourceState::kEnded
            ? absl::OutOfRangeError(absl::StrCat("the source ", pipeline_->source_uri(),
                                                 " has ended; no more frames"))
            : RunStream(context, *plan, *subscription, writer);
    pipeline_->Unsubscribe(subscription);
    return ToGrpcStatus(end);
  }

  grpc::Status GetPixel(grpc::ServerContext* context, const v1::GetPixelRequest* request,
                        v1::Pixel* out) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    return ToGrpcStatus(Pixel(*request, out));
  }

  grpc::Status GetConfig(grpc::ServerContext* context, const v1::GetConfigRequest*,
                         v1::Config* out) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    *out = ToProto(pipeline_->config());
    return grpc::Status::OK;
  }

  grpc::Status SetConfig(grpc::ServerContext* context, const v1::Config* update,
                         v1::Config* out) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    absl::StatusOr<ReconstructionConfig> merged = Merge(pipeline_->config(), *update);
    if (!merged.ok()) return ToGrpcStatus(merged.status());
    if (absl::Status status = pipeline_->SetConfig(*merged); !status.ok()) {
      return ToGrpcStatus(status);
    }
    *out = ToProto(pipeline_->config());
    return grpc::Status::OK;
  }

  grpc::Status Calibrate(grpc::ServerContext* context, const v1::CalibrateRequest* request,
                         grpc::ServerWriter<v1::CalibrateProgress>* writer) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    if (request->takes() > 256) {
      return ToGrpcStatus(absl::InvalidArgumentError(
          absl::StrCat("takes = ", request->takes(), ": expected 1..256 (0 = 20)")));
    }
    const int takes = request->takes() == 0 ? 20 : static_cast<int>(request->takes());
    std::atomic<bool> gone{false};
    auto on_take = [&](int done, int total) {
      v1::CalibrateProgress progress;
      progress.set_done(static_cast<uint32_t>(done));
      progress.set_total(static_cast<uint32_t>(total));
      if (!writer->Write(progress)) gone = true;
    };
    absl::StatusOr<CalibrationOutcome> outcome = pipeline_->Calibrate(
        request->source_uri(), takes, request->output_path(), request->keep_current(), on_take,
        [&] { return gone.load() || context->IsCancelled(); });
    if (!outcome.ok()) return ToGrpcStatus(outcome.status());
    v1::CalibrateProgress last;
    last.set_done(static_cast<uint32_t>(takes));
    last.set_total(static_cast<uint32_t>(takes));
    v1::CalibrateResult* result = last.mutable_result();
    result->set_takes_averaged(static_cast<uint32_t>(outcome->table.takes_averaged));
    result->set_frames_rejected(static_cast<uint32_t>(outcome->frames_rejected));
    result->set_usable_pixels(static_cast<uint64_t>(outcome->usable_pixels));
    result->set_pixels(static_cast<uint64_t>(outcome->table.geometry.pixel_count()));
    result->set_output_path(request->output_path());
    result->set_applied(!request->keep_current());
    writer->Write(last);
    return grpc::Status::OK;
  }

  grpc::Status StartRecording(grpc::ServerContext* context,
                              const v1::StartRecordingRequest* request,
                              v1::Recording* out) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    if (request->deflate_level() > 9) {
      return ToGrpcStatus(absl::InvalidArgumentError(
          absl::StrCat("deflate_level = ", request->deflate_level(), ": expected 1..9 (0 = 1)")));
    }
    const int deflate = request->deflate_level() == 0 ? 1 : static_cast<int>(request->deflate_level());
    absl::StatusOr<RecordingStatus> status =
        pipeline_->StartRecording(request->path(), request->max_frames(), deflate);
    if (!status.ok()) return ToGrpcStatus(status.status());
    ToProto(*status, out);
    return grpc::Status::OK;
  }

  grpc::Status StopRecording(grpc::ServerContext* context, const v1::StopRecordingRequest*,
                             v1::Recording* out) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    absl::StatusOr<RecordingStatus> status = pipeline_->StopRecording();
    if (!status.ok()) return ToGrpcStatus(status.status());
    ToProto(*status, out);
    return grpc::Status::OK;
  }

  grpc::Status GetStats(grpc::ServerContext* context, const v1::GetStatsRequest*,
                        v1::Stats* out) override {
    if (grpc::Status denied = Authorize(*context); !denied.ok()) return denied;
    const PipelineStats s = pipeline_->Stats();
    out->set_raw_frames_in(s.raw_frames_in);
    out->set_raw_frames_dropped(s.raw_frames_dropped);
    out->set_raw_frames_rejected(s.raw_frames_rejected);
    out->set_cycles_assembled(s.cycles_assembled);
    out->set_cycles_dropped(s.cycles_dropped);
    out->set_cycles_refused(s.cycles_refused);
    out->set_frames_reconstructed(s.frames_reconstructed);
    out->set_frames_published(s.frames_published);
    out->set_source_reopens(s.source_reopens);
    out->set_state(ToProto(s.state));
    v1::LatencyStats* latency = out->mutable_latency();
    latency->set_p50_ms(s.latency_p50_ms);
    latency->set_p90_ms(s.latency_p90_ms);
    latency->set_p99_ms(s.latency_p99_ms);
    latency->set_max_ms(s.latency_max_ms);
    out->set_reconstruct_ms_mean(s.reconstruct_ms_mean);
    out->set_frames_per_second(s.frames_per_second);
    for (const SubscriberSnapshot& sub : s.subscribers) {
      v1::SubscriberStats* o = out->add_subscribers();
      o->set_id(sub.id);
      o->set_peer(sub.peer);
      o->set_frames_sent(sub.frames_sent);
      o->set_frames_missed(sub.frames_missed);
      for (v1::Product p : sub.products.List()) o->add_products(p);
    }
    ToProto(s.recording, out->mutable_recording());
    for (const SourceCounter& c : s.source_counters) {
      v1::SourceCounter* o = out->add_source_counters();
      o->set_name(c.name);
      o->set_value(c.value);
      o->set_description(c.description);
    }
    if (nats_ != nullptr) {
      const NatsPublishStats n = nats_->Stats();
      v1::NatsStats* o = out->mutable_nats();
      o->set_servers(n.servers);
      o->set_camera(n.camera);
      o->set_connected(n.connected);
      o->set_frames_published(n.frames_published);
      o->set_messages_published(n.messages_published);
      o->set_messages_acknowledged(n.messages_acknowledged);
      o->set_messages_failed(n.messages_failed);
      o->set_frames_dropped_disconnected(n.frames_dropped_disconnected);
      o->set_frames_dropped_behind(n.frames_dropped_behind);
      o->set_frames_dropped_error(n.frames_dropped_error);
      o->set_disconnects(n.disconnects);
      o->set_reconnects(n.reconnects);
      o->set_last_error(n.last_error);
    }
    return grpc::Status::OK;
  }

 private:
  absl::Status RunStream(grpc::ServerContext* context, const StreamPlan& plan,
                         Subscription& subscription, grpc::ServerWriter<v1::Frame>* writer) {
    absl::Time last_sent = absl::InfinitePast();
    uint64_t missed_pending = 0;
    uint64_t sent = 0;
    const std::string key = wire::EncodingKey(plan.images);
    while (!context->IsCancelled()) {
      uint64_t missed = 0;
      std::shared_ptr<const PublishedFrame> published = subscription.Next(kPollInterval, &missed);
      missed_pending += missed;
      if (published == nullptr) {
        if (subscription.closed()) {
          return absl::UnavailableError("transientd is shutting down");
        }
        continue;
      }
      if (published->announcement) {
        v1::Frame frame;
        frame.set_state(ToProto(published->state));
        *frame.mutable_publish_time() = ToTimestamp(published->publish);
        frame.set_missed(missed_pending);
        missed_pending = 0;
        if (!writer->Write(frame)) return absl::CancelledError("the client went away");
        if (published->state == SourceState::kEnded) {
          return absl::OutOfRangeError(absl::StrCat("the source ", pipeline_->source_uri(),
                                                    " ended after ", sent,
                                                    " frames to this client"));
        }
        continue;
      }
      if (published->publish - last_sent < plan.min_interval) continue;  // max_rate_hz
      absl::StatusOr<std::unique_ptr<StreamMessage>> message =
          MessageForStream(plan, key, *published, missed_pending);
      if (!message.ok()) return message.status();
      if (*message == nullptr)
        continue;  // published before this subscriber's products were computed
      const v1::Frame& frame = (*message)->frame();
      missed_pending = 0;
      if (!writer->Write(frame)) return absl::CancelledError("the client went away");
      last_sent = published->publish;
      ++sent;
    }
    return absl::CancelledError("the client cancelled the stream");
  }

  absl::Status Pixel(const v1::GetPixelRequest& r, v1::Pixel* out) {
    if (const ScheduleOptions schedule = pipeline_->schedule().options();
        schedule.DeliversDepth()) {
      return absl::FailedPreconditionError(absl::StrCat(
          "GetPixel: ",
          schedule.MissingHarmonicsText("the per-pixel density plot of the moment reconstruction"),
          "; stream DEPTH and RANGE instead"));
    }
    std::shared_ptr<const FrameProducts> latest = pipeline_->Latest();
    if (latest == nullptr) {
      return absl::UnavailableError(absl::StrCat("no frame reconstructed yet from ",
                                                 pipeline_->source_uri(), "; retry shortly"));
    }
    const ImageGeometry g = latest->geometry;
    if (r.x() >= static_cast<uint32_t>(g.width) || r.y() >= static_cast<uint32_t>(g.height)) {
      return absl::InvalidArgumentError(absl::StrCat("pixel (", r.x(), ", ", r.y(),
                                                     ") is outside the ", g.width, "x", g.height,
                                                     " sensor"));
    }
    const int bins = r.bins() == 0 ? kDefaultPixelBins : static_cast<int>(std::min<uint32_t>(r.bins(), kMaxPixelBins + 1));
    if (bins > kMaxPixelBins) {
      return absl::InvalidArgumentError(
          absl::StrCat("bins = ", r.bins(), ": expected 1..", kMaxPixelBins, " (0 = 256)"));
    }
    const double bounds_r = r.bounds_r() == 0.0 ? 0.9 : r.bounds_r();
    if (!(bounds_r > 0.0 && bounds_r < 1.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("bounds_r = ", r.bounds_r(), ": expected 0 < r < 1 (0 = 0.9)"));
    }
    if (latest->solved == nullptr) {
      return absl::FailedPreconditionError(absl::StrCat(
          "GetPixel: ", pipeline_->schedule().options().MissingHarmonicsText(
                            "the per-pixel density plot of the moment reconstruction")));
    }
    const int64_t p = int64_t{r.y()} * g.width + r.x();
    const SolvedImage& solved = *latest->solved;
    out->set_sequence(latest->sequence);
    out->set_x(r.x());
    out->set_y(r.y());
    out->set_flags(latest->flags[p]);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    out->set_c0(solved.valid(p) ? solved.c0(p) : nan);
    const std::vector<double> phases = UniformPhases(bins);
    for (double phi : phases) {
      out->add_time_of_flight_ns(PhaseToTimeOfFlightNs(phi, latest->base_frequency_hz));
    }
    if (!solved.valid(p)) {
      out->set_range_m(nan);
      out->set_uniform(nan);
      return absl::OkStatus();  // flags say why; the curves stay empty
    }
    const SolvedImage one = SinglePixel(solved, p);
    std::vector<float> density(phases.size()), cumulative(phases.size()), lower(phases.size()),
        upper(phases.size());
    DensitySlices(one, phases, density);
    CumulativeSlices(one, phases, cumulative);
    BoundSlices(one, bounds_r, phases, lower, upper);
    for (size_t n = 0; n < phases.size(); ++n) {
      out->add_density(density[n]);
      out->add_cumulative(cumulative[n]);
      out->add_lower(lower[n]);
      out->add_upper(upper[n]);
    }
    const PisarenkoImage pisarenko = EstimatePisarenko(one);
    for (int k = 0; k < pisarenko.order; ++k) {
      const float phase = pisarenko.phase[k];
      if (std::isnan(phase)) continue;
      v1::Return* ret = out->add_returns();
      ret->set_time_of_flight_ns(PhaseToTimeOfFlightNs(phase, latest->base_frequency_hz));
      ret->set_range_m(PhaseToRange(phase, latest->base_frequency_hz));
      ret->set_weight(pisarenko.weight[k]);
    }
    out->set_uniform(pisarenko.uniform[0]);
    const ReconstructionConfig config = pipeline_->config();
    const RangeOptions range_options{.base_frequency_hz = latest->base_frequency_hz,
                                     .threshold = config.threshold};
    float range = 0.0f;
    uint8_t flags = one.flags[0];
    if (config.range_method == RangeMethod::kMese) {
      MeseRange(one, range_options, std::span<float>(&range, 1), std::span<uint8_t>(&flags, 1));
    } else {
      PisarenkoRange(pisarenko, range_options, std::span<float>(&range, 1),
                     std::span<uint8_t>(&flags, 1));
    }
    out->set_range_m(range);
    return absl::OkStatus();
  }

  // Every transient.v1 call passes here first (ServerOptions::access).
  grpc::Status Authorize(const grpc::ServerContext& context) const {
    return access_ == nullptr ? grpc::Status::OK : access_->Authorize(context);
  }

  Pipeline* const pipeline_;
  const std::string version_;
  const std::shared_ptr<const Access> access_;
  const NatsPublisher* const nats_;
};

namespace {

// Takes the reflection plugin, which linking grpc++_reflection adds to every server, off one.
class WithoutReflection final : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    std::erase_if(*plugins, [](const std::unique_ptr<grpc::ServerBuilderPlugin>& plugin) {
      return dynamic_cast<grpc::reflection::ProtoServerReflectionPlugin*>(plugin.get()) != nullptr;
    });
  }
};

}  // namespace

absl::StatusOr<std::unique_ptr<TransientServer>> TransientServer::Start(
    Pipeline* pipeline, const ServerOptions& options) {
  std::unique_ptr<TransientServer> server(new TransientServer());
  server->service_ =
      std::make_unique<Service>(pipeline, options.version, options.access, options.nats);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  // Reflection describes the protocol to generic clients (grpcurl); it cannot check a token or
  // a client certificate, so a daemon that requires them serves none.
  if (options.access != nullptr &&
      (options.access->token_required() || options.access->client_certificate_required())) {
    builder.SetOption(std::make_unique<WithoutReflection>());
  }
  int port = 0;
  builder.AddListeningPort(options.listen,
                           options.access != nullptr ? options.access->ServerCredentials()
                                                     : grpc::InsecureServerCredentials(),
                           &port);
  builder.RegisterService(server->service_.get());
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || port == 0) {
    return absl::UnavailableError(absl::StrCat(
        "cannot listen on ", options.listen,
        " (in use, not a local address, or not host:port)"));
  }
  server->port_ = port;
  const size_t colon = options.listen.rfind(':');
  server->host_ = colon == std::string::npos ? options.listen : options.listen.substr(0, colon);
  if (grpc::HealthCheckServiceInterface* health = server->server_->GetHealthCheckService()) {
    health->SetServingStatus("", true);
    health->SetServingStatus(v1::Transient::service_full_name(), true);
  }
  return server;
}

TransientServer::~TransientServer() {
  if (server_ != nullptr) Shutdown(absl::Seconds(1));
}

std::string TransientServer::address() const { return absl::StrCat(host_, ":", port_); }

void TransientServer::Shutdown(absl::Duration deadline) {
  if (server_ == nullptr) return;
  if (grpc::HealthCheckServiceInterface* health = server_->GetHealthCheckService()) {
    health->SetServingStatus(false);
  }
  server_->Shutdown(absl::ToChronoTime(absl::Now() + deadline));
  server_->Wait();
  server_.reset();
}

}  // namespace transient::service

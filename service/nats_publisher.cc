// NatsPublisher: the pipeline's frames to NATS JetStream (nats_publisher.h).
#include "transient/service/nats_publisher.h"

#include <cstdio>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace transient::service {
namespace {

constexpr absl::Duration kPollInterval = absl::Milliseconds(100);
// JetStream's error code for a stream name that exists (jsErrCode JSStreamNameExistErr).
constexpr int kStreamNameExists = 10058;

}  // namespace

absl::StatusOr<std::unique_ptr<NatsPublisher>> NatsPublisher::Start(Pipeline* pipeline,
                                                                    NatsPublishOptions options) {
  if (absl::Status status = wire::CheckNatsCameraName(options.camera); !status.ok()) {
    return status;
  }
  if (options.replicas < 1 || options.replicas > 5) {
    return absl::InvalidArgumentError(
        absl::StrCat("NATS stream replicas = ", options.replicas, ": expected 1..5"));
  }
  if (options.max_age < absl::ZeroDuration() || options.max_bytes < 0) {
    return absl::InvalidArgumentError("NATS stream limits: expected an age and bytes >= 0");
  }
  if (options.request.products_size() == 0) options.request.add_products(v1::MOMENT_STATE);
  absl::StatusOr<StreamPlan> plan = PlanStream(options.request, *pipeline);
  if (!plan.ok()) return plan.status();

  std::unique_ptr<NatsPublisher> p(new NatsPublisher());
  p->pipeline_ = pipeline;
  p->options_ = std::move(options);
  p->plan_ = *std::move(plan);
  p->key_ = wire::EncodingKey(p->plan_.images);

  jsOptions js;
  jsOptions_Init(&js);
  js.Wait = p->options_.connect.timeout_ms;
  js.PublishAsync.MaxPending = p->options_.max_pending;
  js.PublishAsync.AckHandler = &NatsPublisher::OnAck;
  js.PublishAsync.AckHandlerClosure = p.get();
  js.PublishAsync.StallWait = 200;
  if (p->options_.connect.name.empty()) {
    p->options_.connect.name = absl::StrCat("transientd ", p->options_.camera);
  }
  absl::StatusOr<std::unique_ptr<wire::NatsConnection>> connection =
      wire::NatsConnection::Open(p->options_.connect, /*background=*/true, &js);
  if (!connection.ok()) return connection.status();
  p->connection_ = *std::move(connection);
  if (p->connection_->connected()) {
    if (absl::Status status = p->EnsureStream(); !status.ok()) return status;
  }
  absl::StatusOr<std::shared_ptr<Subscription>> subscription = pipeline->Subscribe(
      absl::StrCat("nats:", p->options_.connect.servers), p->plan_.request, p->plan_.queue_frames);
  if (!subscription.ok()) return subscription.status();
  p->subscription_ = *std::move(subscription);
  p->thread_ = std::thread([raw = p.get()] { raw->Run(); });
  return p;
}

NatsPublisher::~NatsPublisher() {
  Stop();
  connection_.reset();  // closed before the members its acknowledgement handler touches
}

void NatsPublisher::Stop() {
  if (stop_.exchange(true)) return;
  if (thread_.joinable()) thread_.join();
  if (connection_ != nullptr && connection_->connected()) {
    jsPubOptions wait;
    jsPubOptions_Init(&wait);
    wait.MaxWait = 1000;
    js_PublishAsyncComplete(connection_->jetstream(), &wait);
  }
  if (subscription_ != nullptr) pipeline_->Unsubscribe(subscription_);
}

void NatsPublisher::OnAck(jsCtx*, natsMsg* msg, jsPubAck* ack, jsPubAckErr* error, void* closure) {
  auto* p = static_cast<NatsPublisher*>(closure);
  if (ack != nullptr && error == nullptr) {
    p->messages_acknowledged_.fetch_add(1);
  } else {
    p->messages_failed_.fetch_add(1);
    if (error != nullptr) {
      absl::MutexLock lock(&p->mu_);
      p->last_error_ = absl::StrCat(
          "JetStream refused or did not acknowledge a message: ", natsStatus_GetText(error->Err),
          error->ErrText != nullptr ? absl::StrCat(" (", error->ErrText, ")") : "");
    }
  }
  natsMsg_Destroy(msg);
}

absl::Status NatsPublisher::EnsureStream() {
  const std::string name = wire::NatsStreamName(options_.camera);
  const std::string subjects = wire::NatsCameraSubjects(options_.camera);
  const char* subject_list[] = {subjects.c_str()};
  jsStreamConfig config;
  jsStreamConfig_Init(&config);
  config.Name = name.c_str();
  config.Subjects = subject_list;
  config.SubjectsLen = 1;
  config.Storage = js_FileStorage;
  config.Retention = js_LimitsPolicy;
  config.Discard = js_DiscardOld;
  config.MaxAge = absl::ToInt64Nanoseconds(options_.max_age);
  config.MaxBytes = options_.max_bytes == 0 ? -1 : options_.max_bytes;
  config.Replicas = options_.replicas;
  jsStreamInfo* info = nullptr;
  jsErrCode code = static_cast<jsErrCode>(0);
  natsStatus s = js_AddStream(&info, connection_->jetstream(), &config, nullptr, &code);
  if (s != NATS_OK && static_cast<int>(code) == kStreamNameExists) {
    s = js_UpdateStream(&info, connection_->jetstream(), &config, nullptr, &code);
  }
  if (info != nullptr) jsStreamInfo_Destroy(info);
  if (s != NATS_OK) {
    return wire::FromNatsStatus(
        s, absl::StrCat("creating the JetStream stream ", name, " (", subjects, ") at ",
                        options_.connect.servers, "; is JetStream enabled (-js)?"));
  }
  stream_epoch_ = connection_->reconnects();
  return absl::OkStatus();
}

bool NatsPublisher::PublishFrame(v1::Frame frame) {
  const int64_t max_payload = connection_->max_payload();
  if (max_payload <= wire::kNatsHeaderRoom) return false;
  const std::string encoding = absl::StrCat(v1::Encoding_Name(plan_.images.encoding), "/",
                                            v1::Compression_Name(plan_.images.compression));
  jsPubOptions publish;
  jsPubOptions_Init(&publish);
  publish.MaxWait = options_.connect.timeout_ms;  // an unacknowledged message fails after this
  for (const wire::NatsMessage& message :
       wire::FrameMessages(std::move(frame), options_.camera, plan_.images.products, encoding,
                           pipeline_->schedule().options().base_frequency_hz,
                           max_payload - wire::kNatsHeaderRoom)) {
    absl::StatusOr<natsMsg*> msg = wire::ToNatsMsg(message);
    natsStatus s =
        msg.ok() ? js_PublishMsgAsync(connection_->jetstream(), &*msg, &publish) : NATS_ERR;
    if (msg.ok()) natsMsg_Destroy(*msg);  // null once the library took it
    if (s != NATS_OK) {
      absl::MutexLock lock(&mu_);
      last_error_ =
          msg.ok()
              ? wire::FromNatsStatus(s, absl::StrCat("publishing ", message.subject)).ToString()
              : msg.status().ToString();
      return false;
    }
    messages_published_.fetch_add(1);
  }
  return true;
}

void NatsPublisher::Run() {
  uint64_t missed_pending = 0;
  while (!stop_.load()) {
    uint64_t missed = 0;
    std::shared_ptr<const PublishedFrame> published = subscription_->Next(kPollInterval, &missed);
    dropped_behind_.fetch_add(missed);
    missed_pending += missed;
    if (published == nullptr) {
      if (subscription_->closed()) return;
      continue;
    }
    if (published->announcement) continue;  // a state change: the frames' absence says it
    if (!connection_->connected()) {
      dropped_disconnected_.fetch_add(1);
      ++missed_pending;
      continue;
    }
    if (stream_epoch_ != connection_->reconnects()) {
      // A server that came back may be a new one without the stream.
      if (absl::Status status = EnsureStream(); !status.ok()) {
        absl::MutexLock lock(&mu_);
        last_error_ = status.ToString();
        dropped_error_.fetch_add(1);
        ++missed_pending;
        continue;
      }
    }
    absl::StatusOr<std::optional<v1::Frame>> frame =
        FrameForStream(plan_, key_, *published, missed_pending);
    if (!frame.ok()) {
      absl::MutexLock lock(&mu_);
      last_error_ = frame.status().ToString();
      dropped_error_.fetch_add(1);
      continue;
    }
    if (!frame->has_value()) continue;  // published before the products were computed
    if (PublishFrame(*std::move(*frame))) {
      frames_published_.fetch_add(1);
      missed_pending = 0;
    } else {
      dropped_error_.fetch_add(1);
      ++missed_pending;
    }
  }
}

NatsPublishStats NatsPublisher::Stats() const {
  NatsPublishStats s;
  s.servers = options_.connect.servers;
  s.camera = options_.camera;
  s.connected = connection_ != nullptr && connection_->connected();
  s.frames_published = frames_published_.load();
  s.messages_published = messages_published_.load();
  s.messages_acknowledged = messages_acknowledged_.load();
  s.messages_failed = messages_failed_.load();
  s.frames_dropped_disconnected = dropped_disconnected_.load();
  s.frames_dropped_behind = dropped_behind_.load();
  s.frames_dropped_error = dropped_error_.load();
  if (connection_ != nullptr) {
    s.disconnects = connection_->disconnects();
    s.reconnects = connection_->reconnects();
  }
  absl::MutexLock lock(&mu_);
  s.last_error = last_error_;
  return s;
}

}  // namespace transient::service

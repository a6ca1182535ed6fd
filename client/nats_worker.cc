// NatsWorker: a camera's heavy products computed from its MOMENT_STATE frames, shared between
// workers through one durable JetStream consumer (nats_worker.h).
#include "transient/client/nats_worker.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "transient/reconstruct/frame_products.h"
#include "transient/reconstruct/image.h"
#include "transient/wire/product_encoder.h"

namespace transient::client {
namespace {

// Owns the messages of a fetch.
struct FetchedList {
  natsMsgList list{};
  ~FetchedList() { natsMsgList_Destroy(&list); }
};

}  // namespace

absl::StatusOr<SolvedImage> SolvedFromMomentState(const std::vector<DecodedImage>& images) {
  SolvedImage s;
  int order = -1;
  for (const DecodedImage& image : images) {
    if (image.product != v1::MOMENT_STATE) continue;
    if (order < 0) s.geometry = image.geometry;
    if (image.geometry.width != s.geometry.width || image.geometry.height != s.geometry.height) {
      return absl::DataLossError(absl::StrCat(
          "MOMENT_STATE image ", image.name, " is ", image.geometry.width, "x",
          image.geometry.height, ", the others ", s.geometry.width, "x", s.geometry.height));
    }
    order = std::max(order, image.index);
  }
  if (order < 1) return absl::DataLossError("no MOMENT_STATE images of harmonics 1 or more");
  s.order = order;
  const size_t pixels = static_cast<size_t>(s.geometry.pixel_count());
  const size_t planes = static_cast<size_t>(order + 1);
  const double nan = std::nan("");
  s.c_real.assign(planes * pixels, nan);
  s.c_imag.assign(planes * pixels, 0.0);  // plane 0 is zero
  s.q_real.assign(planes * pixels, nan);
  s.q_imag.assign(planes * pixels, nan);
  std::vector<int> seen(4 * planes, 0);
  for (const DecodedImage& image : images) {
    if (image.product != v1::MOMENT_STATE) continue;
    std::vector<double>* target = nullptr;
    int which = 0;
    switch (image.kind) {
      case wire::ImageKind::kCReal:
        target = &s.c_real;
        which = 0;
        break;
      case wire::ImageKind::kCImag:
        target = &s.c_imag;
        which = 1;
        break;
      case wire::ImageKind::kQReal:
        target = &s.q_real;
        which = 2;
        break;
      case wire::ImageKind::kQImag:
        target = &s.q_imag;
        which = 3;
        break;
      default:
        continue;
    }
    if (image.values.size() != pixels) {
      return absl::DataLossError(absl::StrCat("MOMENT_STATE image ", image.name, ": ",
                                              image.values.size(), " values for ", pixels,
                                              " pixels"));
    }
    std::copy(image.values.begin(), image.values.end(),
              target->begin() + static_cast<ptrdiff_t>(image.index * pixels));
    ++seen[static_cast<size_t>(which) * planes + static_cast<size_t>(image.index)];
  }
  for (size_t j = 0; j < planes; ++j) {
    const bool complete = seen[j] == 1 && (j == 0 || seen[planes + j] == 1) &&
                          seen[2 * planes + j] == 1 && seen[3 * planes + j] == 1;
    if (!complete) {
      return absl::DataLossError(
          absl::StrCat("MOMENT_STATE: the planes of harmonic ", j, " are missing or repeated"));
    }
  }
  s.flags.assign(pixels, 0);
  for (size_t p = 0; p < pixels; ++p) {
    if (std::isnan(s.q_real[p]) || std::isnan(s.c_real[p])) s.flags[p] = kFlagInvalidInput;
  }
  return s;
}

absl::StatusOr<std::unique_ptr<NatsWorker>> NatsWorker::Open(const NatsWorkerOptions& options) {
  if (absl::Status status = wire::CheckNatsCameraName(options.camera); !status.ok()) {
    return status;
  }
  if (absl::Status status = wire::CheckNatsCameraName(options.group); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("worker group: ", status.message()));
  }
  if (options.products.empty()) {
    return absl::InvalidArgumentError(
        "worker products: expected slices, cumulative and/or direct_indirect");
  }
  for (v1::Product product : options.products) {
    if (product != v1::SLICES && product != v1::CUMULATIVE && product != v1::DIRECT_INDIRECT) {
      return absl::InvalidArgumentError(
          absl::StrCat("worker products: ", v1::Product_Name(product),
                       " is not computed by workers; expected SLICES, CUMULATIVE and/or "
                       "DIRECT_INDIRECT"));
    }
  }
  if (options.bins < 1 || options.bins > wire::kMaxSlices) {
    return absl::InvalidArgumentError(
        absl::StrCat("worker bins = ", options.bins, ": expected 1..", wire::kMaxSlices));
  }
  if (options.ack_wait < absl::Seconds(1)) {
    return absl::InvalidArgumentError("worker ack wait: expected at least 1 s");
  }
  std::unique_ptr<NatsWorker> w(new NatsWorker());
  w->options_ = options;
  absl::StatusOr<std::unique_ptr<wire::NatsConnection>> connection =
      wire::NatsConnection::Open(options.connect, /*background=*/false);
  if (!connection.ok()) return connection.status();
  w->connection_ = *std::move(connection);

  const std::string stream = wire::NatsStreamName(options.camera);
  const std::string subject = wire::NatsSubject(options.camera, v1::MOMENT_STATE);
  jsSubOptions sub;
  jsSubOptions_Init(&sub);
  sub.Stream = stream.c_str();
  sub.Config.AckPolicy = js_AckExplicit;
  sub.Config.AckWait = absl::ToInt64Nanoseconds(options.ack_wait);
  sub.Config.DeliverPolicy = js_DeliverNew;
  sub.Config.MaxAckPending = 64;
  jsErrCode code = static_cast<jsErrCode>(0);
  const natsStatus status =
      js_PullSubscribe(&w->subscription_, w->connection_->jetstream(), subject.c_str(),
                       options.group.c_str(), nullptr, &sub, &code);
  if (status != NATS_OK) {
    return wire::FromNatsSubscribeStatus(status, code,
                                         absl::StrCat("joining the workers ", options.group, " of ",
                                                      subject, " at ", options.connect.servers),
                                         options.camera);
  }
  return w;
}

NatsWorker::~NatsWorker() {
  // The durable consumer stays for the group's other workers: only this subscription goes.
  if (subscription_ != nullptr) natsSubscription_Destroy(subscription_);
}

absl::Status NatsWorker::Publish(v1::Frame frame, double base_frequency_hz) {
  const int64_t max_payload = connection_->max_payload();
  const std::string encoding = absl::StrCat(v1::Encoding_Name(options_.encoding), "/",
                                            v1::Compression_Name(options_.compression));
  for (const wire::NatsMessage& message :
       wire::FrameMessages(std::move(frame), options_.camera, options_.products, encoding,
                           base_frequency_hz, max_payload - wire::kNatsHeaderRoom)) {
    absl::StatusOr<natsMsg*> msg = wire::ToNatsMsg(message);
    if (!msg.ok()) return msg.status();
    jsPubAck* ack = nullptr;
    jsErrCode code = static_cast<jsErrCode>(0);
    const natsStatus s =
        js_PublishMsg(&ack, connection_->jetstream(), *msg, nullptr, &code);  // stored, or not
    natsMsg_Destroy(*msg);
    if (ack != nullptr) jsPubAck_Destroy(ack);
    if (s != NATS_OK) {
      return wire::FromNatsStatus(s, absl::StrCat("publishing ", message.subject));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<bool> NatsWorker::ProcessOne(absl::Duration wait) {
  FetchedList fetched;
  jsErrCode code = static_cast<jsErrCode>(0);
  const natsStatus s =
      natsSubscription_Fetch(&fetched.list, subscription_, 1,
                             std::max<int64_t>(1, absl::ToInt64Milliseconds(wait)), &code);
  if (s == NATS_TIMEOUT || (s == NATS_OK && fetched.list.Count == 0)) return false;
  if (s != NATS_OK) return wire::FromNatsStatus(s, "fetching a frame");
  natsMsg* msg = fetched.list.Msgs[0];
  jsMsgMetaData* meta = nullptr;
  bool redelivered = false;
  if (natsMsg_GetMetaData(&meta, msg) == NATS_OK) {
    redelivered = meta->NumDelivered > 1;
    jsMsgMetaData_Destroy(meta);
  }
  const absl::string_view part = wire::NatsHeader(msg, wire::kNatsPartHeader);
  double base_frequency_hz = 0.0;
  v1::Frame frame;
  absl::StatusOr<std::vector<DecodedImage>> images = absl::DataLossError("");
  if (!(part.empty() || part == "1/1")) {
    images = absl::FailedPreconditionError(
        absl::StrCat("frame in parts (", part,
                     "): workers need a frame in one message; publish with "
                     "--nats-encoding float16 --nats-zstd or raise the server's max_payload"));
  } else if (!absl::SimpleAtod(wire::NatsHeader(msg, wire::kNatsBaseFrequencyHeader),
                               &base_frequency_hz) ||
             !(base_frequency_hz > 0.0)) {
    images = absl::DataLossError(
        absl::StrCat("no ", wire::kNatsBaseFrequencyHeader, " header with a frequency > 0"));
  } else if (!frame.ParseFromArray(natsMsg_GetData(msg), natsMsg_GetDataLength(msg))) {
    images = absl::DataLossError("the message is not a transient.v1.Frame");
  } else {
    images = DecodeFrame(frame);
  }
  absl::StatusOr<SolvedImage> solved =
      images.ok() ? SolvedFromMomentState(*images) : absl::StatusOr<SolvedImage>(images.status());
  if (!solved.ok()) {
    // Not a frame a worker can use: never again (no redelivery), counted.
    natsMsg_Term(msg, nullptr);
    ++counts_.frames_refused;
    last_refusal_ = solved.status();
    return true;
  }
  ProductNeeds needs;
  const std::vector<double> phases = UniformPhases(options_.bins);
  for (v1::Product product : options_.products) {
    if (product == v1::SLICES) needs.slice_phases[phases].density = true;
    if (product == v1::CUMULATIVE) needs.slice_phases[phases].cumulative = true;
    if (product == v1::DIRECT_INDIRECT) needs.direct_indirect = true;
  }
  const ImageGeometry geometry = solved->geometry;
  std::shared_ptr<const FrameProducts> products =
      ComputeProducts(std::make_shared<const SolvedImage>(*std::move(solved)), CameraInfo{},
                      {.base_frequency_hz = base_frequency_hz}, needs, frame.sequence());
  wire::ProductEncoding plan;
  plan.products = options_.products;
  plan.rect = {0, 0, geometry.width, geometry.height};
  plan.encoding = options_.encoding;
  plan.compression = options_.compression;
  plan.slice_phases = phases;
  v1::Frame out;
  absl::StatusOr<bool> encoded = wire::EncodeProducts(plan, *products, &out);
  if (!encoded.ok() || !*encoded) {
    natsMsg_Term(msg, nullptr);
    ++counts_.frames_refused;
    last_refusal_ =
        encoded.ok() ? absl::InternalError("a product was not computed") : encoded.status();
    return true;
  }
  out.set_sequence(frame.sequence());
  out.set_capture_time_s(frame.capture_time_s());
  out.set_state(frame.state());
  *out.mutable_publish_time() = frame.publish_time();
  out.set_latency_s(frame.latency_s());
  out.set_missed(frame.missed());
  *out.mutable_roi() = frame.roi();
  if (absl::Status published = Publish(std::move(out), base_frequency_hz); !published.ok()) {
    ++counts_.publish_failures;
    natsMsg_Nak(msg, nullptr);  // to another worker, or to this one again
    return published;
  }
  // Acknowledged only now that its products are stored: a worker dying before this line leaves
  // the frame to be delivered again.
  if (natsStatus ack = natsMsg_AckSync(msg, nullptr, nullptr); ack != NATS_OK) {
    return wire::FromNatsStatus(ack, absl::StrCat("acknowledging frame ", frame.sequence()));
  }
  ++counts_.frames_done;
  if (redelivered) ++counts_.frames_redelivered;
  done_.push_back(frame.sequence());
  return true;
}

}  // namespace transient::client

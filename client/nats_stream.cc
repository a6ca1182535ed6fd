// NatsFrameStream: an ordered JetStream consumer of one product of a camera (nats_stream.h).
#include "transient/client/nats_stream.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace transient::client {
namespace {

constexpr int64_t kPollMs = 100;

}  // namespace

absl::Status ParseNatsStart(const std::string& option, const std::string& text,
                            NatsStreamOptions* options) {
  uint64_t sequence = 0;
  if (text == "new") {
    options->start = NatsStreamOptions::Start::kNew;
  } else if (text == "all") {
    options->start = NatsStreamOptions::Start::kAll;
  } else if (absl::StartsWith(text, "seq:") && absl::SimpleAtoi(text.substr(4), &sequence) &&
             sequence >= 1) {
    options->start = NatsStreamOptions::Start::kSequence;
    options->start_sequence = sequence;
  } else if (double seconds = 0.0; absl::StartsWith(text, "ago:") &&
                                   absl::SimpleAtod(text.substr(4), &seconds) &&
                                   std::isfinite(seconds) && seconds >= 0.0) {
    options->start = NatsStreamOptions::Start::kTime;
    options->start_time = absl::Now() - absl::Seconds(seconds);
  } else if (absl::Time time; absl::StartsWith(text, "time:") &&
                              absl::ParseTime(absl::RFC3339_full, text.substr(5), &time, nullptr)) {
    options->start = NatsStreamOptions::Start::kTime;
    options->start_time = time;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat(option, " '", text,
                     "': expected new, all, seq:N (a stream sequence >= 1), ago:SECONDS or "
                     "time:RFC3339 (2026-12-03T10:00:00Z)"));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<NatsFrameStream>> NatsFrameStream::Open(
    const NatsStreamOptions& options) {
  if (absl::Status status = wire::CheckNatsCameraName(options.camera); !status.ok()) {
    return status;
  }
  if (options.start == NatsStreamOptions::Start::kSequence && options.start_sequence == 0) {
    return absl::InvalidArgumentError("NATS start sequence: expected 1 or more");
  }
  std::unique_ptr<NatsFrameStream> s(new NatsFrameStream());
  s->options_ = options;
  absl::StatusOr<std::unique_ptr<wire::NatsConnection>> connection =
      wire::NatsConnection::Open(options.connect, /*background=*/false);
  if (!connection.ok()) return connection.status();
  s->connection_ = *std::move(connection);

  const std::string stream = wire::NatsStreamName(options.camera);
  const std::string subject = wire::NatsSubject(options.camera, options.product);
  jsSubOptions sub;
  jsSubOptions_Init(&sub);
  sub.Stream = stream.c_str();
  sub.Ordered = true;  // in order, no gaps: recreated by the library from the last sequence seen
  switch (options.start) {
    case NatsStreamOptions::Start::kNew:
      sub.Config.DeliverPolicy = js_DeliverNew;
      break;
    case NatsStreamOptions::Start::kAll:
      sub.Config.DeliverPolicy = js_DeliverAll;
      break;
    case NatsStreamOptions::Start::kSequence:
      sub.Config.DeliverPolicy = js_DeliverByStartSequence;
      sub.Config.OptStartSeq = options.start_sequence;
      break;
    case NatsStreamOptions::Start::kTime:
      sub.Config.DeliverPolicy = js_DeliverByStartTime;
      sub.Config.OptStartTime = absl::ToUnixNanos(options.start_time);
      break;
  }
  jsErrCode code = static_cast<jsErrCode>(0);
  natsStatus status = js_SubscribeSync(&s->subscription_, s->connection_->jetstream(),
                                       subject.c_str(), nullptr, &sub, &code);
  if (status != NATS_OK) {
    return wire::FromNatsSubscribeStatus(status, code,
                                         absl::StrCat("subscribing to ", subject, " in stream ",
                                                      stream, " at ", options.connect.servers),
                                         options.camera);
  }
  // Frames of a few MB each: let the library hold a few hundred MB of them, not its default.
  natsSubscription_SetPendingLimits(s->subscription_, 65536, 512 << 20);
  return s;
}

NatsFrameStream::~NatsFrameStream() {
  if (subscription_ != nullptr) {
    natsSubscription_Unsubscribe(subscription_);
    natsSubscription_Destroy(subscription_);
  }
}

bool NatsFrameStream::Next(StreamFrame* frame) {
  while (true) {
    if (cancelled_.load() || (options_.cancel != nullptr && options_.cancel->load())) {
      cancelled_.store(true);
      return false;
    }
    const absl::Time now = absl::Now();
    if (now >= options_.deadline) {
      past_deadline_ = true;
      return false;
    }
    const int64_t wait_ms =
        std::clamp<int64_t>(absl::ToInt64Milliseconds(options_.deadline - now), 1, kPollMs);
    natsMsg* msg = nullptr;
    const natsStatus s = natsSubscription_NextMsg(&msg, subscription_, wait_ms);
    if (s != NATS_OK) {
      // A timeout, the server away, or a heartbeat missed: the ordered consumer resumes.
      if (msg != nullptr) natsMsg_Destroy(msg);
      continue;
    }
    uint64_t sequence = 0;
    (void)absl::SimpleAtoi(wire::NatsHeader(msg, wire::kNatsSequenceHeader), &sequence);
    const absl::string_view part = wire::NatsHeader(msg, wire::kNatsPartHeader);
    double frequency = 0.0;
    if (absl::SimpleAtod(wire::NatsHeader(msg, wire::kNatsBaseFrequencyHeader), &frequency)) {
      base_frequency_hz_ = frequency;
    }
    const absl::string_view data(natsMsg_GetData(msg),
                                 static_cast<size_t>(natsMsg_GetDataLength(msg)));
    jsMsgMetaData* meta = nullptr;
    if (natsMsg_GetMetaData(&meta, msg) == NATS_OK) {
      stream_sequence_ = meta->Sequence.Stream;
      jsMsgMetaData_Destroy(meta);
    }
    v1::Frame wire_frame;
    std::string error;
    const wire::FrameAssembler::Result result =
        assembler_.Add(sequence, part, data, &wire_frame, &error);
    natsMsg_Destroy(msg);
    if (result == wire::FrameAssembler::Result::kIncomplete) continue;
    const absl::Time arrival = absl::Now();
    if (result == wire::FrameAssembler::Result::kBad) {
      *frame = StreamFrame{};
      frame->arrival = arrival;
      frame->sequence = sequence;
      frame->kind = StreamFrame::Kind::kCorrupt;
      frame->corruption = absl::DataLossError(
          absl::StrCat("NATS message of frame ", sequence, " on ",
                       wire::NatsSubject(options_.camera, options_.product), ": ", error));
      last_corruption_ = frame->corruption;
      ++counts_.corrupt;
      return true;
    }
    DecodeStreamMessage(wire_frame, arrival, frame, &counts_, &last_corruption_);
    // Frames whose parts this consumer did not all receive count as missed here.
    const int64_t incomplete = assembler_.abandoned() - incomplete_reported_;
    incomplete_reported_ = assembler_.abandoned();
    frame->missed += static_cast<uint64_t>(incomplete);
    counts_.missed += static_cast<uint64_t>(incomplete);
    return true;
  }
}

absl::Status NatsFrameStream::Finish() {
  if (cancelled_.load()) {
    return absl::CancelledError(absl::StrCat("NATS stream of ", options_.camera,
                                             " cancelled after ", counts_.frames, " frames"));
  }
  return absl::OkStatus();
}

}  // namespace transient::client

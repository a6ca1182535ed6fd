// FrameStream: reads StreamFrames messages, decodes them, and tells our own end of the call
// (cancel, deadline, an early Finish) from the daemon's.
#include "transient/client/frame_stream.h"

#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "stream_watcher.h"
#include "transient/wire/grpc_status.h"

namespace transient::client {

void DecodeStreamMessage(const v1::Frame& wire, absl::Time arrival, StreamFrame* frame,
                         StreamCounts* counts, absl::Status* last_corruption) {
  *frame = StreamFrame{};
  frame->arrival = arrival;
  frame->sequence = wire.sequence();
  frame->capture_time_s = wire.capture_time_s();
  frame->state = wire.state();
  frame->missed = wire.missed();
  counts->missed += wire.missed();
  if (wire.has_publish_time() && std::isfinite(wire.latency_s())) {
    const absl::Time published = absl::FromUnixSeconds(wire.publish_time().seconds()) +
                                 absl::Nanoseconds(wire.publish_time().nanos());
    frame->latency_s = wire.latency_s() + absl::ToDoubleSeconds(frame->arrival - published);
  }
  if (wire.images_size() == 0) {
    frame->kind = StreamFrame::Kind::kAnnouncement;
    ++counts->announcements;
    return;
  }
  absl::StatusOr<std::vector<DecodedImage>> images = DecodeFrame(wire);
  if (!images.ok()) {
    frame->kind = StreamFrame::Kind::kCorrupt;
    frame->corruption = images.status();
    *last_corruption = images.status();
    ++counts->corrupt;
    return;
  }
  frame->kind = StreamFrame::Kind::kImages;
  frame->images = *std::move(images);
  ++counts->frames;
}

FrameStream::FrameStream(std::shared_ptr<grpc::Channel> channel, std::string address,
                         const v1::StreamRequest& request, const StreamOptions& options)
    : address_(std::move(address)), stub_(v1::Transient::NewStub(std::move(channel))) {
  reader_ = stub_->StreamFrames(&context_, request);
  if (options.cancel != nullptr || options.deadline != absl::InfiniteFuture()) {
    watcher_ = std::make_unique<StreamWatcher>(&context_, options.cancel, options.deadline);
  }
}

FrameStream::~FrameStream() { (void)Finish(); }

bool FrameStream::Next(StreamFrame* frame) {
  if (ended_ || finished_) return false;
  v1::Frame wire;
  if (!reader_->Read(&wire)) {
    ended_ = true;
    return false;
  }
  DecodeStreamMessage(wire, absl::Now(), frame, &counts_, &last_corruption_);
  return true;
}

void FrameStream::Cancel() {
  cancelled_.store(true);
  context_.TryCancel();
}

absl::Status FrameStream::Finish() {
  if (finished_) return status_;
  // Still running: the caller is done with it before its end, and the CANCELLED the call then
  // ends with is ours, not the daemon's.
  const bool stopped_early = !ended_;
  if (stopped_early) context_.TryCancel();
  v1::Frame rest;
  while (reader_->Read(&rest)) {
  }  // what was in flight, before Finish
  const grpc::Status status = reader_->Finish();
  const StreamWatcher::Reason reason =
      watcher_ != nullptr ? watcher_->reason() : StreamWatcher::Reason::kNone;
  watcher_.reset();  // joins its thread; it may no longer touch the context
  finished_ = true;
  const bool ours = stopped_early || cancelled_.load() || reason != StreamWatcher::Reason::kNone;
  if (status.error_code() == grpc::StatusCode::CANCELLED && ours) {
    status_ = cancelled_.load() || reason == StreamWatcher::Reason::kInterrupted
                  ? absl::CancelledError(absl::StrCat("stream from transientd at ", address_,
                                                      " cancelled after ", counts_.frames,
                                                      " frames"))
                  : absl::OkStatus();
  } else {
    status_ = wire::FromGrpcStatus(status);
  }
  return status_;
}

}  // namespace transient::client

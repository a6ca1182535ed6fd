// Subscribers' bounded queues.
#include "transient/service/subscription.h"

#include <algorithm>
#include <utility>

namespace transient::service {

std::shared_ptr<const v1::Frame> EncodedImages::Find(const std::string& key) const {
  absl::MutexLock lock(&mu_);
  for (const auto& [k, images] : images_) {
    if (k != key) continue;
    ++hits_;
    return images;
  }
  return nullptr;
}

std::shared_ptr<const v1::Frame> EncodedImages::Insert(const std::string& key,
                                                       std::shared_ptr<const v1::Frame> images) {
  absl::MutexLock lock(&mu_);
  if (cleared_) return images;  // no longer the newest frame: nothing is kept for it
  for (const auto& [k, stored] : images_) {
    if (k == key) return stored;  // another stream encoded it meanwhile
  }
  images_.emplace_back(key, images);
  return images;
}

void EncodedImages::Clear() {
  absl::MutexLock lock(&mu_);
  images_.clear();
  cleared_ = true;
}

int64_t EncodedImages::hits() const {
  absl::MutexLock lock(&mu_);
  return hits_;
}

const char* SourceStateName(SourceState state) {
  switch (state) {
    case SourceState::kStreaming: return "streaming";
    case SourceState::kReconnecting: return "reconnecting";
    case SourceState::kEnded: return "ended";
  }
  return "unknown";
}

Subscription::Subscription(uint64_t id, std::string peer, ProductRequest request,
                           int queue_frames)
    : id_(id),
      peer_(std::move(peer)),
      request_(std::move(request)),
      capacity_(static_cast<size_t>(std::max(1, queue_frames))) {}

void Subscription::Push(std::shared_ptr<const PublishedFrame> frame) {
  absl::MutexLock lock(&mu_);
  if (closed_) return;
  // Frames drop oldest-first; announcements only when the queue holds nothing else (the newest
  // state, pushed last, always stays).
  while (queue_.size() >= capacity_) {
    auto oldest = std::find_if(queue_.begin(), queue_.end(),
                               [](const auto& f) { return !f->announcement; });
    if (oldest == queue_.end()) {
      queue_.pop_front();
      continue;
    }
    queue_.erase(oldest);
    ++missed_since_last_;
    ++missed_total_;
  }
  queue_.push_back(std::move(frame));
}

std::shared_ptr<const PublishedFrame> Subscription::Next(absl::Duration timeout,
                                                         uint64_t* missed) {
  absl::MutexLock lock(&mu_);
  auto ready = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return closed_ || !queue_.empty(); };
  mu_.AwaitWithTimeout(absl::Condition(&ready), timeout);
  if (queue_.empty()) return nullptr;
  std::shared_ptr<const PublishedFrame> frame = std::move(queue_.front());
  queue_.pop_front();
  *missed = missed_since_last_;
  missed_since_last_ = 0;
  if (!frame->announcement) ++delivered_;
  return frame;
}

void Subscription::Close() {
  absl::MutexLock lock(&mu_);
  closed_ = true;
}

bool Subscription::closed() const {
  absl::MutexLock lock(&mu_);
  return closed_;
}

uint64_t Subscription::frames_delivered() const {
  absl::MutexLock lock(&mu_);
  return delivered_;
}

uint64_t Subscription::frames_missed() const {
  absl::MutexLock lock(&mu_);
  return missed_total_;
}

}  // namespace transient::service

#include "transient/service/pipeline.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/formats/calibration_file.h"
#include "transient/formats/hdf5_lock.h"
#include "transient/drivers/replay_source.h"
#include "transient/drivers/simulator.h"
#include "transient/reconstruct/cycle_assembler.h"
#include "transient/reconstruct/demodulation.h"
#include "transient/reconstruct/smoothing.h"

namespace transient::service {
namespace {

constexpr absl::Duration kNextTimeout = absl::Milliseconds(100);
constexpr size_t kLatencyWindow = 1024;
constexpr int kMaxTakes = 64;
constexpr uint64_t kMaxRecordingFrames = uint64_t{1} << 32;

bool IsFastReplay(const std::string& uri) {
  if (!absl::StartsWith(uri, "replay:")) return false;
  std::string path;
  absl::StatusOr<ReplayOptions> options = ParseReplayUri(uri, &path);
  return options.ok() && options->pace == ReplayPace::kFast;
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + static_cast<ptrdiff_t>(k), values.end());
  return values[k];
}

// The source of a Calibrate RPC: each call holds the HDF5 mutex only for itself (a replay reads
// HDF5), so the stream goes on meanwhile; Next fails with Cancelled once the client went away
// or the pipeline stops, so that neither waits for a calibration that cannot finish.
class CalibrationSource final : public CaptureSource {
 public:
  CalibrationSource(std::unique_ptr<CaptureSource> inner, std::function<bool()> cancelled)
      : inner_(std::move(inner)), cancelled_(std::move(cancelled)) {}
  const std::string& uri() const override { return inner_->uri(); }
  const CameraInfo& camera() const override { return inner_->camera(); }
  const AcquisitionSchedule& schedule() const override { return inner_->schedule(); }
  SourceCapabilities capabilities() const override { return inner_->capabilities(); }
  absl::Status Start() override {
    absl::MutexLock lock(&Hdf5Mutex());
    return inner_->Start();
  }
  absl::Status Stop() override {
    absl::MutexLock lock(&Hdf5Mutex());
    return inner_->Stop();
  }
  absl::Status Next(absl::Duration timeout, RawFrame* frame) override {
    // Short waits, so that cancellation is noticed within kNextTimeout.
    const absl::Time end = absl::Now() + timeout;
    while (true) {
      if (cancelled_()) return absl::CancelledError("calibration cancelled");
      absl::Status status;
      {
        absl::MutexLock lock(&Hdf5Mutex());
        status = inner_->Next(std::min(kNextTimeout, end - absl::Now()), frame);
      }
      if (!absl::IsDeadlineExceeded(status) || absl::Now() >= end) return status;
    }
  }

 private:
  std::unique_ptr<CaptureSource> inner_;
  std::function<bool()> cancelled_;
};

// One item of the queue between the source and the reconstruction thread: a complete capture
// cycle, or a state change (kept in order with the frames).
struct CycleItem {
  std::vector<RawFrame> frames;
  std::shared_ptr<const AcquisitionSchedule> schedule;
  absl::Time arrival;
  bool announcement = false;
  SourceState state = SourceState::kStreaming;
};

}  // namespace

const char* SourceStateName(SourceState state) {
  switch (state) {
    case SourceState::kStreaming: return "streaming";
    case SourceState::kReconnecting: return "reconnecting";
    case SourceState::kEnded: return "ended";
  }
  return "unknown";
}

absl::Status ReconstructionConfig::Validate() const {
  const SolveOptions solve{.bias_epsilon = bias_epsilon};
  if (absl::Status status = solve.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("bias_epsilon: ", status.message()));
  }
  if (!(threshold > 0.0 && threshold < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("threshold = ", threshold, ": expected 0 < threshold < 1"));
  }
  if (absl::Status status = ValidateSmoothingSigma(smoothing_sigma_px); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("smoothing_sigma_px: ", status.message()));
  }
  if (takes < 1 || takes > kMaxTakes) {
    return absl::InvalidArgumentError(
        absl::StrCat("takes = ", takes, ": expected 1..", kMaxTakes));
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Subscription

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

// ---------------------------------------------------------------------------------------------
// Pipeline internals

struct Pipeline::Impl {
  explicit Impl(PipelineOptions o) : options(std::move(o)) {}

  void Log(const std::string& line) {
    if (options.log) options.log(line);
  }

  // Source thread ------------------------------------------------------------------------------
  void SourceLoop();
  bool OpenSourceLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  void CloseSourceLocked(const std::string& reason) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  void ServeRecordingRequests(const RawFrame* frame, bool final) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  void Record(const RawFrame& frame) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  void FinishRecordingLocked(const std::string& error) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  void Announce(SourceState state);
  void PushCycle(CycleItem item);
  void SleepInterruptibly(absl::Duration duration);

  // Reconstruction thread ----------------------------------------------------------------------
  void ReconstructLoop();
  void Reconstruct(CycleItem& item);
  void Publish(std::shared_ptr<const PublishedFrame> frame);
  ProductNeeds CurrentNeeds();

  PipelineOptions options;
  std::atomic<bool> stopping{false};
  std::thread source_thread, reconstruct_thread;
  std::atomic<bool> started{false};
  bool block_when_full = false;  // a fast replay: never drop a recorded cycle

  // Source, assembler and recorder: source thread, under Hdf5Mutex().
  std::unique_ptr<CaptureSource> source;
  std::optional<CycleAssembler> assembler;
  std::shared_ptr<const AcquisitionSchedule> source_schedule;
  std::optional<CaptureWriter> writer;
  uint64_t record_limit_raw = 0;  // 0 = until stopped
  uint64_t source_frames_lost = 0;        // DataLoss from the source
  uint64_t assembler_dropped_before = 0;  // by assemblers of sources closed since
  bool record_waiting_for_cycle_start = false;

  // Reconstruction thread only: rebuilt when the schedule or the config changes.
  struct ReconstructState {
    std::shared_ptr<const AcquisitionSchedule> schedule;
    uint64_t config_version = ~uint64_t{0};
    std::optional<Demodulator> demodulator;
    MomentImage moments;
    DemodulationReport report;
    uint64_t sequence = 0;
    // Solved images recycled once no frame holds them any more: at 640x480 a fresh one costs
    // ~50 MB of page faults per frame.
    std::vector<std::shared_ptr<SolvedImage>> solved_pool;
  } reconstruct_state;

  Pipeline* owner = nullptr;
  CameraInfo camera;  // of the source at Create; a reopened source must keep the geometry

  // Everything else.
  mutable absl::Mutex mu;
  std::string source_uri ABSL_GUARDED_BY(mu);
  std::shared_ptr<const AcquisitionSchedule> schedule ABSL_GUARDED_BY(mu);
  bool reopen_requested ABSL_GUARDED_BY(mu) = false;
  ReconstructionConfig config ABSL_GUARDED_BY(mu);
  uint64_t config_version ABSL_GUARDED_BY(mu) = 0;
  std::shared_ptr<const CalibrationTable> calibration ABSL_GUARDED_BY(mu);
  std::string calibration_origin ABSL_GUARDED_BY(mu);
  SourceState state ABSL_GUARDED_BY(mu) = SourceState::kStreaming;
  std::vector<std::shared_ptr<Subscription>> subscriptions ABSL_GUARDED_BY(mu);
  uint64_t next_subscription_id ABSL_GUARDED_BY(mu) = 1;
  std::shared_ptr<const FrameProducts> latest ABSL_GUARDED_BY(mu);
  PipelineStats stats ABSL_GUARDED_BY(mu);
  std::deque<double> latencies_ms ABSL_GUARDED_BY(mu);
  std::deque<absl::Time> reconstruct_times ABSL_GUARDED_BY(mu);
  double reconstruct_ms_total ABSL_GUARDED_BY(mu) = 0.0;
  RecordingStatus recording ABSL_GUARDED_BY(mu);
  // A StartRecording waiting for the source thread to create the file.
  struct PendingRecording {
    std::string path;
    uint64_t max_frames = 0;
    int deflate_level = 1;
    bool done = false;
    absl::Status result;
  };
  std::shared_ptr<PendingRecording> pending_recording ABSL_GUARDED_BY(mu);
  bool stop_recording_requested ABSL_GUARDED_BY(mu) = false;

  // The queue between the threads.
  absl::Mutex queue_mu;
  std::deque<CycleItem> cycles ABSL_GUARDED_BY(queue_mu);
};

bool Pipeline::Impl::OpenSourceLocked() {
  std::string uri;
  {
    absl::MutexLock lock(&mu);
    uri = source_uri;
    reopen_requested = false;
  }
  SourceOpener open = options.open_source
                          ? options.open_source
                          : [](const std::string& u) { return transient::OpenSource(u); };
  absl::StatusOr<std::unique_ptr<CaptureSource>> opened = open(uri);
  if (!opened.ok()) {
    Log(absl::StrCat("source: cannot open ", uri, ": ", opened.status().message()));
    return false;
  }
  absl::Status started_status = (*opened)->Start();
  if (!started_status.ok()) {
    Log(absl::StrCat("source: cannot start ", uri, ": ", started_status.message()));
    return false;
  }
  source = *std::move(opened);
  source_schedule = std::make_shared<const AcquisitionSchedule>(source->schedule());
  absl::StatusOr<CycleAssembler> created =
      CycleAssembler::Create(*source_schedule, source->camera().geometry);
  if (!created.ok()) {
    Log(absl::StrCat("source: ", created.status().message()));
    source.reset();
    return false;
  }
  assembler.emplace(*std::move(created));
  absl::MutexLock lock(&mu);
  schedule = source_schedule;
  return true;
}

void Pipeline::Impl::CloseSourceLocked(const std::string& reason) {
  // A recording holds one source's frames under one schedule: it ends with that source.
  if (writer.has_value()) FinishRecordingLocked(absl::StrCat("stopped: ", reason));
  if (assembler.has_value()) {
    assembler_dropped_before += static_cast<uint64_t>(assembler->dropped_frames());
  }
  if (source != nullptr) (void)source->Stop();
  source.reset();
  assembler.reset();
}

void Pipeline::Impl::SleepInterruptibly(absl::Duration duration) {
  const absl::Time end = absl::Now() + duration;
  while (!stopping.load() && absl::Now() < end) {
    absl::SleepFor(std::min(absl::Milliseconds(20), end - absl::Now()));
  }
}

void Pipeline::Impl::Announce(SourceState new_state) {
  {
    absl::MutexLock lock(&mu);
    if (state == new_state) return;
    state = new_state;
    stats.state = new_state;
  }
  Log(absl::StrCat("source: ", SourceStateName(new_state)));
  CycleItem item;
  item.announcement = true;
  item.state = new_state;
  PushCycle(std::move(item));
}

void Pipeline::Impl::PushCycle(CycleItem item) {
  absl::MutexLock lock(&queue_mu);
  // Announcements take no room (the bound is on frames) and are not dropped for frames; of a
  // burst of them (a source failing again and again) only the latest 8 are kept.
  if (item.announcement) {
    constexpr size_t kMaxAnnouncements = 8;
    while (std::count_if(cycles.begin(), cycles.end(),
                         [](const CycleItem& c) { return c.announcement; }) >=
           static_cast<ptrdiff_t>(kMaxAnnouncements)) {
      cycles.erase(std::find_if(cycles.begin(), cycles.end(),
                                [](const CycleItem& c) { return c.announcement; }));
    }
    cycles.push_back(std::move(item));
    return;
  }
  const size_t capacity = static_cast<size_t>(std::max(1, options.cycle_queue_frames));
  auto frames_queued = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(queue_mu) {
    return static_cast<size_t>(std::count_if(cycles.begin(), cycles.end(),
                                             [](const CycleItem& c) { return !c.announcement; }));
  };
  if (block_when_full) {
    auto has_room = [this, capacity, &frames_queued]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(queue_mu) {
      return stopping.load() || frames_queued() < capacity;
    };
    while (!has_room()) queue_mu.AwaitWithTimeout(absl::Condition(&has_room), kNextTimeout);
  }
  while (frames_queued() >= capacity) {
    auto oldest = std::find_if(cycles.begin(), cycles.end(),
                               [](const CycleItem& c) { return !c.announcement; });
    cycles.erase(oldest);
    absl::MutexLock stats_lock(&mu);
    ++stats.cycles_dropped;
  }
  cycles.push_back(std::move(item));
}

// Serves StopRecording, and StartRecording with the frame that begins the file. Without a frame
// a StartRecording waits for one, unless `final` (no frame will come): then it fails.
void Pipeline::Impl::ServeRecordingRequests(const RawFrame* frame, bool final) {
  std::shared_ptr<PendingRecording> pending;
  bool stop_requested = false;
  {
    absl::MutexLock lock(&mu);
    // Without a frame a StartRecording stays pending (unless final): taken only when served,
    // so that its own timeout can withdraw it.
    if (frame != nullptr || final) {
      pending = pending_recording;
      pending_recording = nullptr;
    }
    stop_requested = stop_recording_requested;
    stop_recording_requested = false;
  }
  if (stop_requested) FinishRecordingLocked("");
  if (pending == nullptr) return;
  absl::Status result;
  if (writer.has_value()) {
    result = absl::FailedPreconditionError(
        absl::StrCat("a recording to ", writer->path(), " is in progress"));
  } else if (frame == nullptr || source == nullptr) {
    absl::MutexLock lock(&mu);
    result = absl::FailedPreconditionError(absl::StrCat(
        "the source ", source_uri, " is ", SourceStateName(state), "; no frames to record"));
  } else {
    // Created with the first frame's saturation level, as `transient record` does.
    CaptureWriterOptions writer_options{.pixel_type = CapturePixelType::kFloat32,
                                        .deflate_level = pending->deflate_level,
                                        .source_uri = source->uri(),
                                        .saturation_level = frame->saturation_level};
    absl::StatusOr<CaptureWriter> created = CaptureWriter::Create(
        pending->path, source->camera(), *source_schedule, writer_options);
    if (created.ok()) {
      absl::StatusOr<GroundTruth> truth = source->GroundTruthAt(frame->config.timestamp_s);
      if (truth.ok()) result = created->SetGroundTruth(*truth);
      std::shared_ptr<const CalibrationTable> table;
      {
        absl::MutexLock lock(&mu);
        table = calibration;
      }
      if (result.ok() && table != nullptr) result = created->EmbedCalibration(*table);
      if (result.ok()) {
        writer.emplace(*std::move(created));
        record_limit_raw = pending->max_frames *  // max_frames <= kMaxRecordingFrames
                           static_cast<uint64_t>(source_schedule->raw_frames_per_frame());
        record_waiting_for_cycle_start = true;
        absl::MutexLock lock(&mu);
        recording = RecordingStatus{.path = pending->path, .active = true, .error = {}};
      } else {
        (void)created->Close();
        std::error_code ignored;
        std::filesystem::remove(pending->path, ignored);
      }
    } else {
      result = created.status();
    }
  }
  if (result.ok()) Log(absl::StrCat("recording: started ", pending->path));
  absl::MutexLock lock(&mu);
  pending->result = result;
  pending->done = true;
}

void Pipeline::Impl::Record(const RawFrame& frame) {
  ServeRecordingRequests(&frame, false);
  if (!writer.has_value()) return;
  if (record_waiting_for_cycle_start) {
    // The file begins with a whole capture cycle: take 0, first exposure.
    absl::StatusOr<int> index = source_schedule->IndexOf(frame.config);
    if (!index.ok() || *index != 0) return;
    record_waiting_for_cycle_start = false;
  }
  if (absl::Status status = writer->Append(frame); !status.ok()) {
    FinishRecordingLocked(absl::StrCat("stopped: ", status.message()));
    return;
  }
  {
    absl::MutexLock lock(&mu);
    recording.raw_frames = static_cast<uint64_t>(writer->frames());
    recording.flushed_frames = static_cast<uint64_t>(writer->flushed_frames());
  }
  if (record_limit_raw > 0 && static_cast<uint64_t>(writer->frames()) >= record_limit_raw) {
    FinishRecordingLocked("");
  }
}

void Pipeline::Impl::FinishRecordingLocked(const std::string& error) {
  if (!writer.has_value()) return;
  std::string message = error;
  if (absl::Status status = writer->Close(); !status.ok() && message.empty()) {
    message = absl::StrCat("closing failed: ", status.message());
  }
  const uint64_t frames = static_cast<uint64_t>(writer->frames());
  const std::string path = writer->path();
  writer.reset();
  absl::MutexLock lock(&mu);
  recording.active = false;
  recording.raw_frames = frames;
  recording.flushed_frames = frames;
  recording.error = message;
  Log(absl::StrCat("recording: ", path, " closed with ", frames, " raw frames",
                   message.empty() ? "" : "; ", message));
}

void Pipeline::Impl::SourceLoop() {
  absl::Duration backoff = options.reopen_backoff_min;
  bool ended = false;
  RawFrame frame;
  while (!stopping.load()) {
    if (ended) {
      // A finished replay: nothing more to read; recordings and RPCs still work.
      {
        absl::MutexLock lock(&Hdf5Mutex());
        ServeRecordingRequests(nullptr, true);
      }
      SleepInterruptibly(kNextTimeout);
      continue;
    }
    bool reopen;
    {
      absl::MutexLock lock(&mu);
      reopen = reopen_requested;
    }
    if (source == nullptr || reopen) {
      bool opened;
      {
        absl::MutexLock lock(&Hdf5Mutex());
        if (reopen) CloseSourceLocked("the source was reopened with a new schedule");
        opened = OpenSourceLocked();
      }
      if (!opened) {
        {
          absl::MutexLock lock(&Hdf5Mutex());
          ServeRecordingRequests(nullptr, true);
        }
        Announce(SourceState::kReconnecting);
        SleepInterruptibly(backoff);
        backoff = std::min(backoff * 2, options.reopen_backoff_max);
        continue;
      }
      if (reopen) {
        absl::MutexLock lock(&mu);
        ++stats.source_reopens;
      }
      Announce(SourceState::kStreaming);
    }
    absl::Status next;
    bool complete = false;
    {
      absl::MutexLock lock(&Hdf5Mutex());
      next = source->Next(kNextTimeout, &frame);
      if (next.ok()) {
        Record(frame);
        absl::StatusOr<bool> added = assembler->Add(frame);
        complete = added.ok() && *added;
        absl::MutexLock stats_lock(&mu);
        ++stats.raw_frames_in;
        stats.raw_frames_dropped = source_frames_lost + assembler_dropped_before +
                                   static_cast<uint64_t>(assembler->dropped_frames());
      } else {
        ServeRecordingRequests(nullptr, false);
      }
      if (absl::IsOutOfRange(next)) {
        CloseSourceLocked(absl::StrCat(source->uri(), " ended"));
      } else if (!next.ok() && !absl::IsDeadlineExceeded(next) && !absl::IsDataLoss(next)) {
        CloseSourceLocked(absl::StrCat("the source failed: ", next.message()));
      }
    }
    if (next.ok()) {
      backoff = options.reopen_backoff_min;  // only a source that delivers resets the backoff
      if (complete) {
        CycleItem item;
        item.frames = assembler->TakeCycle();
        item.schedule = source_schedule;
        item.arrival = absl::Now();
        {
          absl::MutexLock lock(&mu);
          ++stats.cycles_assembled;
        }
        PushCycle(std::move(item));
      }
      continue;
    }
    if (absl::IsDeadlineExceeded(next)) continue;
    if (absl::IsDataLoss(next)) {
      Log(absl::StrCat("source: frame dropped: ", next.message()));
      ++source_frames_lost;
      absl::MutexLock lock(&mu);
      ++stats.raw_frames_dropped;
      continue;
    }
    if (absl::IsOutOfRange(next)) {
      Log(absl::StrCat("source: ", next.message()));
      ended = true;
      Announce(SourceState::kEnded);
      continue;
    }
    // Unavailable (the device was lost) or anything else: reopen with backoff.
    Log(absl::StrCat("source: ", next.message(), "; reopening"));
    {
      absl::MutexLock lock(&mu);
      ++stats.source_reopens;
    }
    Announce(SourceState::kReconnecting);
    SleepInterruptibly(backoff);
    backoff = std::min(backoff * 2, options.reopen_backoff_max);
  }
  absl::MutexLock lock(&Hdf5Mutex());
  FinishRecordingLocked("");
  ServeRecordingRequests(nullptr, true);  // a StartRecording still waiting fails now
  CloseSourceLocked("the daemon stopped");
}

ProductNeeds Pipeline::Impl::CurrentNeeds() {
  ProductNeeds needs;
  absl::MutexLock lock(&mu);
  for (const auto& s : subscriptions) {
    const ProductRequest& r = s->request();
    needs.products |= r.products;
    if (r.products.Has(v1::SLICES)) needs.slice_phases[r.slice_phases].density = true;
    if (r.products.Has(v1::CUMULATIVE)) needs.slice_phases[r.slice_phases].cumulative = true;
    if (r.products.Has(v1::MOMENT_DEPTH) &&
        std::find(needs.moment_depth.begin(), needs.moment_depth.end(), r.moment_depth) ==
            needs.moment_depth.end()) {
      needs.moment_depth.push_back(r.moment_depth);
    }
  }
  return needs;
}

void Pipeline::Impl::Publish(std::shared_ptr<const PublishedFrame> frame) {
  std::vector<std::shared_ptr<Subscription>> targets;
  {
    absl::MutexLock lock(&mu);
    targets = subscriptions;
    if (!frame->announcement) {
      ++stats.frames_published;
      latencies_ms.push_back(absl::ToDoubleMilliseconds(frame->publish - frame->arrival));
      if (latencies_ms.size() > kLatencyWindow) latencies_ms.pop_front();
    }
  }
  for (const auto& s : targets) s->Push(frame);
}

void Pipeline::Impl::Reconstruct(CycleItem& item) {
  ReconstructState& st = reconstruct_state;

  ReconstructionConfig cfg;
  uint64_t version;
  std::shared_ptr<const CalibrationTable> table;
  {
    absl::MutexLock lock(&mu);
    cfg = config;
    version = config_version;
    table = calibration;  // Calibrate may replace it meanwhile; this one stays valid
  }
  const absl::Time begin = absl::Now();
  const ImageGeometry geometry = item.frames.front().geometry;
  if (st.schedule != item.schedule || st.config_version != version) {
    absl::StatusOr<Demodulator> created =
        Demodulator::Create(*item.schedule, geometry, DemodulationOptions{.video = cfg.video});
    if (!created.ok()) {
      Log(absl::StrCat("reconstruction: ", created.status().message()));
      absl::MutexLock lock(&mu);
      ++stats.cycles_refused;
      return;
    }
    st.demodulator.emplace(*std::move(created));
    st.schedule = item.schedule;
    st.config_version = version;
  }
  absl::Status status = st.demodulator->Demodulate(item.frames, &st.moments, &st.report);
  if (status.ok() && table != nullptr) status = ApplyCalibration(*table, &st.moments);
  if (status.ok()) status = GaussianSmooth(cfg.smoothing_sigma_px, &st.moments);
  if (!status.ok()) {
    Log(absl::StrCat("reconstruction: cycle refused: ", status.message()));
    absl::MutexLock lock(&mu);
    ++stats.cycles_refused;
    return;
  }
  const ZerothMoment zeroth = item.schedule->options().zeroth == ZerothScheme::kEstimated
                                  ? ZerothMoment::kEstimate
                                  : ZerothMoment::kMeasured;
  std::shared_ptr<SolvedImage> solved;
  for (const auto& candidate : st.solved_pool) {
    // Only the pool holds it: no published frame (nor Latest()) can reach it any more.
    if (candidate.use_count() == 1) {
      // Orders our writes after the last reader's release of its reference.
      std::atomic_thread_fence(std::memory_order_acquire);
      solved = candidate;
      break;
    }
  }
  if (solved == nullptr) {
    solved = std::make_shared<SolvedImage>();
    if (st.solved_pool.size() < 8) st.solved_pool.push_back(solved);
  }
  Solve(st.moments, SolveOptions{.bias_epsilon = cfg.bias_epsilon, .zeroth = zeroth},
        solved.get());
  const ProductOptions product_options{
      .base_frequency_hz = item.schedule->options().base_frequency_hz,
      .range_method = cfg.range_method,
      .threshold = cfg.threshold};
  const uint64_t sequence = st.sequence++;
  std::shared_ptr<const FrameProducts> products =
      ComputeProducts(std::move(solved), camera, product_options, CurrentNeeds(), sequence);

  auto frame = std::make_shared<PublishedFrame>();
  frame->sequence = sequence;
  double first = item.frames.front().config.timestamp_s;
  for (const RawFrame& f : item.frames) first = std::min(first, f.config.timestamp_s);
  frame->capture_time_s = first;
  frame->arrival = item.arrival;
  frame->products = products;
  frame->publish = absl::Now();
  {
    absl::MutexLock lock(&mu);
    latest = products;
    ++stats.frames_reconstructed;
    stats.raw_frames_rejected += st.report.rejected.size();
    reconstruct_ms_total += absl::ToDoubleMilliseconds(frame->publish - begin);
    reconstruct_times.push_back(frame->publish);
    while (reconstruct_times.size() > 1 &&
           reconstruct_times.front() < frame->publish - absl::Seconds(5)) {
      reconstruct_times.pop_front();
    }
  }
  Publish(std::move(frame));
}

void Pipeline::Impl::ReconstructLoop() {
  absl::Time last_log = absl::Now();
  while (true) {
    std::optional<CycleItem> item;
    {
      absl::MutexLock lock(&queue_mu);
      auto ready = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(queue_mu) {
        return stopping.load() || !cycles.empty();
      };
      queue_mu.AwaitWithTimeout(absl::Condition(&ready), kNextTimeout);
      if (stopping.load()) return;
      if (!cycles.empty()) {
        item.emplace(std::move(cycles.front()));
        cycles.pop_front();
      }
    }
    if (item.has_value()) {
      if (item->announcement) {
        auto frame = std::make_shared<PublishedFrame>();
        frame->announcement = true;
        frame->state = item->state;
        frame->publish = absl::Now();
        Publish(std::move(frame));
      } else {
        Reconstruct(*item);
      }
    }
    if (options.log && absl::Now() - last_log >= options.stats_log_interval) {
      last_log = absl::Now();
      const PipelineStats s = owner->Stats();
      Log(absl::StrFormat(
          "stats: %d raw frames in, %d frames reconstructed (%.1f/s), %d published, %d cycles "
          "dropped, %d refused, latency p50 %.1f ms p99 %.1f ms, %d subscribers",
          s.raw_frames_in, s.frames_reconstructed, s.frames_per_second, s.frames_published,
          s.cycles_dropped, s.cycles_refused, s.latency_p50_ms, s.latency_p99_ms,
          s.subscribers.size()));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Pipeline

absl::StatusOr<std::string> CalibrationSourceFor(const std::string& source_uri) {
  if (!absl::StartsWith(source_uri, "sim:")) {
    return absl::InvalidArgumentError(absl::StrCat(
        "source_uri: required for ", source_uri,
        " (only a simulator has a calibration scene; point a camera into its light source, "
        "thesis fig. 8.3, and name that source)"));
  }
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(source_uri);
  if (!options.ok()) return options.status();
  options->scene = "calibration";
  options->pace = Pace::kFast;
  options->frames = 0;
  return FormatSimulatorUri(*options);
}

Pipeline::Pipeline(PipelineOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

Pipeline::~Pipeline() { Stop(); }

absl::StatusOr<std::unique_ptr<Pipeline>> Pipeline::Create(PipelineOptions options) {
  if (absl::Status status = options.config.Validate(); !status.ok()) return status;
  std::unique_ptr<Pipeline> pipeline(new Pipeline(std::move(options)));
  Impl& impl = *pipeline->impl_;
  impl.owner = pipeline.get();
  {
    absl::MutexLock lock(&impl.mu);
    impl.source_uri = impl.options.source_uri;
    if (impl.options.calibration.has_value()) {
      impl.calibration = std::make_shared<const CalibrationTable>(*impl.options.calibration);
    }
    impl.calibration_origin = impl.options.calibration_origin;
    impl.config = impl.options.config;
  }
  {
    absl::MutexLock lock(&Hdf5Mutex());
    SourceOpener open = impl.options.open_source
                            ? impl.options.open_source
                            : [](const std::string& u) { return transient::OpenSource(u); };
    absl::StatusOr<std::unique_ptr<CaptureSource>> opened = open(impl.options.source_uri);
    if (!opened.ok()) return opened.status();
    impl.camera = (*opened)->camera();
    const AcquisitionSchedule& schedule = (*opened)->schedule();
    if (impl.options.calibration.has_value()) {
      if (absl::Status status = CheckCalibrationMatches(*impl.options.calibration,
                                                        schedule.options(), impl.camera.geometry);
          !status.ok()) {
        return absl::FailedPreconditionError(absl::StrCat(
            impl.options.calibration_origin, " does not fit ", impl.options.source_uri, ": ",
            status.message()));
      }
    }
    absl::MutexLock state_lock(&impl.mu);
    impl.schedule = std::make_shared<const AcquisitionSchedule>(schedule);
    impl.config.takes = schedule.options().takes;
    impl.block_when_full = IsFastReplay(impl.options.source_uri);
    // Opened again by the source thread (Start), so that reopening follows one path.
  }
  return pipeline;
}

void Pipeline::Start() {
  if (impl_->started.exchange(true)) return;
  impl_->source_thread = std::thread([this] { impl_->SourceLoop(); });
  impl_->reconstruct_thread = std::thread([this] { impl_->ReconstructLoop(); });
}

void Pipeline::Stop() {
  if (impl_->stopping.exchange(true)) return;
  if (impl_->source_thread.joinable()) impl_->source_thread.join();
  if (impl_->reconstruct_thread.joinable()) impl_->reconstruct_thread.join();
  std::vector<std::shared_ptr<Subscription>> subscriptions;
  {
    absl::MutexLock lock(&impl_->mu);
    subscriptions.swap(impl_->subscriptions);
  }
  for (const auto& s : subscriptions) s->Close();
  if (!impl_->started) {
    absl::MutexLock lock(&Hdf5Mutex());
    impl_->CloseSourceLocked("the daemon stopped");
  }
}

const CameraInfo& Pipeline::camera() const { return impl_->camera; }

std::string Pipeline::source_uri() const {
  absl::MutexLock lock(&impl_->mu);
  return impl_->source_uri;
}

AcquisitionSchedule Pipeline::schedule() const {
  absl::MutexLock lock(&impl_->mu);
  return *impl_->schedule;
}

std::string Pipeline::calibration_origin() const {
  absl::MutexLock lock(&impl_->mu);
  return impl_->calibration_origin;
}

SourceState Pipeline::state() const {
  absl::MutexLock lock(&impl_->mu);
  return impl_->state;
}

absl::StatusOr<std::shared_ptr<Subscription>> Pipeline::Subscribe(std::string peer,
                                                                  ProductRequest request,
                                                                  int queue_frames) {
  absl::MutexLock lock(&impl_->mu);
  if (impl_->subscriptions.size() >= static_cast<size_t>(kMaxSubscribers)) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "transientd serves at most ", kMaxSubscribers, " streams at once; ",
        impl_->subscriptions.size(), " are open"));
  }
  // Slices are computed once per distinct list for all subscribers: bound their sum.
  if (request.products.Has(v1::SLICES) || request.products.Has(v1::CUMULATIVE)) {
    std::map<std::vector<double>, int> planes;  // phase list -> density and/or cumulative
    auto count = [&planes](const ProductRequest& r) {
      int& n = planes[r.slice_phases];
      n |= (r.products.Has(v1::SLICES) ? 1 : 0) | (r.products.Has(v1::CUMULATIVE) ? 2 : 0);
    };
    for (const auto& s : impl_->subscriptions) {
      if (s->request().products.Has(v1::SLICES) || s->request().products.Has(v1::CUMULATIVE)) {
        count(s->request());
      }
    }
    count(request);
    int64_t bytes = 0;
    for (const auto& [phases, kinds] : planes) {
      bytes += static_cast<int64_t>(phases.size()) * ((kinds & 1) + ((kinds >> 1) & 1)) *
               impl_->camera.geometry.pixel_count() * 4;
    }
    if (bytes > kMaxSliceBytesAllStreams) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "slices: with this request the daemon would compute ", bytes >> 20,
          " MiB of slices per frame for all streams together; at most ",
          kMaxSliceBytesAllStreams >> 20, " MiB (ask for the slice lists other streams use)"));
    }
  }
  // Moment depth maps are computed once per distinct spec for all subscribers: bound them.
  if (request.products.Has(v1::MOMENT_DEPTH)) {
    std::set<MomentDepthSpec> specs = {request.moment_depth};
    for (const auto& s : impl_->subscriptions) {
      if (s->request().products.Has(v1::MOMENT_DEPTH)) specs.insert(s->request().moment_depth);
    }
    if (specs.size() > static_cast<size_t>(kMaxMomentDepthSpecs)) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "moment_depth: with this request the daemon would compute ", specs.size(),
          " different moment depth maps per frame; at most ", kMaxMomentDepthSpecs,
          " (ask for the near_m, far_m, sigma_px, ",
          "bits and from_returns other streams use)"));
    }
  }
  auto subscription = std::make_shared<Subscription>(impl_->next_subscription_id++,
                                                     std::move(peer), std::move(request),
                                                     queue_frames);
  if (impl_->stopping.load()) {
    subscription->Close();
  } else {
    impl_->subscriptions.push_back(subscription);
  }
  return subscription;
}

void Pipeline::Unsubscribe(const std::shared_ptr<Subscription>& subscription) {
  subscription->Close();
  absl::MutexLock lock(&impl_->mu);
  std::erase(impl_->subscriptions, subscription);
}

std::shared_ptr<const FrameProducts> Pipeline::Latest() const {
  absl::MutexLock lock(&impl_->mu);
  return impl_->latest;
}

ReconstructionConfig Pipeline::config() const {
  absl::MutexLock lock(&impl_->mu);
  return impl_->config;
}

absl::Status Pipeline::SetConfig(const ReconstructionConfig& config) {
  if (absl::Status status = config.Validate(); !status.ok()) return status;
  {
  absl::MutexLock lock(&impl_->mu);
  if (config.takes != impl_->config.takes) {
    if (impl_->state == SourceState::kEnded) {
      return absl::FailedPreconditionError(
          absl::StrCat("takes: the source ", impl_->source_uri, " has ended"));
    }
    if (!absl::StartsWith(impl_->source_uri, "sim:")) {
      return absl::FailedPreconditionError(absl::StrCat(
          "takes: the source ", impl_->source_uri, " fixes its schedule (", impl_->config.takes,
          " takes); only a simulator source can change it"));
    }
    absl::StatusOr<SimulatorOptions> sim = ParseSimulatorUri(impl_->source_uri);
    if (!sim.ok()) return sim.status();
    sim->schedule.takes = config.takes;
    if (absl::Status status = sim->schedule.Validate(); !status.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("takes: ", status.message()));
    }
    impl_->source_uri = FormatSimulatorUri(*sim);
    impl_->reopen_requested = true;
  }
  impl_->config = config;
  ++impl_->config_version;
  }
  impl_->Log(absl::StrFormat(
      "config: range %s, bias_epsilon %g, threshold %g, smoothing %g px, %d takes, video %s",
      config.range_method == RangeMethod::kMese ? "mese" : "pisarenko", config.bias_epsilon,
      config.threshold, config.smoothing_sigma_px, config.takes, config.video ? "on" : "off"));
  return absl::OkStatus();
}

absl::StatusOr<CalibrationOutcome> Pipeline::Calibrate(
    const std::string& source_uri, int takes, const std::string& output_path, bool keep_current,
    const std::function<void(int, int)>& on_take, const std::function<bool()>& cancelled) {
  if (takes < 1 || takes > 256) {
    return absl::InvalidArgumentError(absl::StrCat("takes = ", takes, ": expected 1..256"));
  }
  std::string uri = source_uri;
  std::string stream_uri;
  std::shared_ptr<const AcquisitionSchedule> schedule;
  {
    absl::MutexLock lock(&impl_->mu);
    stream_uri = impl_->source_uri;
    schedule = impl_->schedule;
  }
  if (uri.empty()) {
    absl::StatusOr<std::string> derived = CalibrationSourceFor(stream_uri);
    if (!derived.ok()) return derived.status();
    uri = *derived;
  }
  if (!output_path.empty() && std::filesystem::exists(output_path)) {
    return absl::AlreadyExistsError(
        absl::StrCat("output_path: ", output_path, " exists; a calibration never replaces a file"));
  }
  std::unique_ptr<CaptureSource> opened_source;
  {
    absl::MutexLock lock(&Hdf5Mutex());  // a replay source reads HDF5 when opened
    SourceOpener open = impl_->options.open_source
                            ? impl_->options.open_source
                            : [](const std::string& u) { return transient::OpenSource(u); };
    absl::StatusOr<std::unique_ptr<CaptureSource>> opened = open(uri);
    if (!opened.ok()) return opened.status();
    opened_source = *std::move(opened);
  }
  CalibrationSource source(std::move(opened_source), [this, &cancelled] {
    return impl_->stopping.load() || (cancelled && cancelled());
  });
  absl::StatusOr<CalibrationCapture> measured =
      CaptureCalibration(source, takes, {.on_take = on_take});
  if (!measured.ok()) return measured.status();
  if (absl::Status status = CheckCalibrationMatches(measured->table, schedule->options(),
                                                    impl_->camera.geometry);
      !status.ok()) {
    return absl::FailedPreconditionError(
        absl::StrCat(uri, " does not fit the stream of ", stream_uri, ": ", status.message()));
  }
  if (!output_path.empty()) {
    // Never replaces a file, neither one made meanwhile nor one of a concurrent Calibrate.
    absl::Status status;
    {
      absl::MutexLock lock(&Hdf5Mutex());
      status = WriteCalibrationFile(output_path, measured->table, CommitMode::kNeverReplace);
    }
    if (!status.ok()) {
      return absl::Status(status.code(), absl::StrCat("output_path: ", status.message()));
    }
  }
  if (!keep_current) {
    const std::string origin =
        output_path.empty() ? absl::StrCat("measured from ", uri) : output_path;
    {
      absl::MutexLock lock(&impl_->mu);
      impl_->calibration = std::make_shared<const CalibrationTable>(measured->table);
      impl_->calibration_origin = origin;
    }
    impl_->Log(absl::StrCat("calibration: now ", origin));
  }
  return CalibrationOutcome{.table = std::move(measured->table),
                            .frames_rejected = measured->frames_rejected,
                            .usable_pixels = measured->usable_pixels};
}

absl::StatusOr<RecordingStatus> Pipeline::StartRecording(const std::string& path,
                                                         uint64_t max_frames, int deflate_level) {
  if (path.empty()) return absl::InvalidArgumentError("path: expected a file name");
  if (deflate_level < 0 || deflate_level > 9) {
    return absl::InvalidArgumentError(
        absl::StrCat("deflate_level = ", deflate_level, ": expected 0..9"));
  }
  if (max_frames > kMaxRecordingFrames) {
    return absl::InvalidArgumentError(absl::StrCat("max_frames = ", max_frames, ": expected 0..",
                                                   kMaxRecordingFrames, " (0 = until stopped)"));
  }
  if (std::filesystem::exists(path)) {
    return absl::AlreadyExistsError(
        absl::StrCat("path: ", path, " exists; a recording never replaces a file"));
  }
  auto pending = std::make_shared<Impl::PendingRecording>();
  pending->path = path;
  pending->max_frames = max_frames;
  pending->deflate_level = deflate_level;
  absl::MutexLock lock(&impl_->mu);
  if (impl_->recording.active) {
    return absl::FailedPreconditionError(
        absl::StrCat("a recording to ", impl_->recording.path, " is in progress"));
  }
  if (impl_->pending_recording != nullptr) {
    return absl::FailedPreconditionError("another StartRecording is being served");
  }
  if (!impl_->started || impl_->stopping.load()) {
    return absl::FailedPreconditionError("the pipeline is not running");
  }
  impl_->pending_recording = pending;
  auto done = [&pending]() -> bool { return pending->done; };
  if (!impl_->mu.AwaitWithTimeout(absl::Condition(&done), absl::Seconds(10))) {
    if (impl_->pending_recording == pending) impl_->pending_recording = nullptr;
    return absl::UnavailableError(absl::StrCat(
        "no frame from ", impl_->source_uri, " within 10 s to begin the recording (",
        SourceStateName(impl_->state), ")"));
  }
  if (!pending->result.ok()) return pending->result;
  return impl_->recording;
}

absl::StatusOr<RecordingStatus> Pipeline::StopRecording() {
  absl::MutexLock lock(&impl_->mu);
  if (!impl_->recording.active) {
    return absl::FailedPreconditionError(
        impl_->recording.path.empty()
            ? std::string("no recording in progress")
            : absl::StrCat("no recording in progress; the last was ", impl_->recording.path,
                           impl_->recording.error.empty() ? "" : " (",
                           impl_->recording.error, impl_->recording.error.empty() ? "" : ")"));
  }
  impl_->stop_recording_requested = true;
  auto stopped = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(impl_->mu) {
    return !impl_->recording.active || impl_->stopping.load();
  };
  if (!impl_->mu.AwaitWithTimeout(absl::Condition(&stopped), absl::Seconds(10))) {
    return absl::UnavailableError("the recording did not close within 10 s");
  }
  return impl_->recording;
}

PipelineStats Pipeline::Stats() const {
  absl::MutexLock lock(&impl_->mu);
  PipelineStats s = impl_->stats;
  s.state = impl_->state;
  std::vector<double> latencies(impl_->latencies_ms.begin(), impl_->latencies_ms.end());
  s.latency_p50_ms = Percentile(latencies, 0.50);
  s.latency_p90_ms = Percentile(latencies, 0.90);
  s.latency_p99_ms = Percentile(latencies, 0.99);
  s.latency_max_ms = latencies.empty() ? 0.0 : *std::max_element(latencies.begin(), latencies.end());
  if (s.frames_reconstructed > 0) {
    s.reconstruct_ms_mean = impl_->reconstruct_ms_total / s.frames_reconstructed;
  }
  if (impl_->reconstruct_times.size() >= 2) {
    s.frames_per_second =
        (impl_->reconstruct_times.size() - 1) /
        absl::ToDoubleSeconds(impl_->reconstruct_times.back() - impl_->reconstruct_times.front());
  }
  for (const auto& sub : impl_->subscriptions) {
    s.subscribers.push_back(SubscriberSnapshot{.id = sub->id(),
                                               .peer = sub->peer(),
                                               .frames_sent = sub->frames_delivered(),
                                               .frames_missed = sub->frames_missed(),
                                               .products = sub->request().products});
  }
  s.recording = impl_->recording;
  return s;
}

}  // namespace transient::service

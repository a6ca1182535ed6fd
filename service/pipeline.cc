#include "transient/service/pipeline.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <set>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "cycle_queue.h"
#include "live_calibration.h"
#include "reconstruction_stage.h"
#include "recorder.h"
#include "transient/drivers/source_registry.h"
#include "transient/formats/hdf5_lock.h"
#include "transient/reconstruct/cycle_assembler.h"
#include "transient/reconstruct/frame_pipeline.h"

namespace transient::service {

namespace {

constexpr absl::Duration kNextTimeout = absl::Milliseconds(100);

// What a client may name as Calibrate's source (docs/security.md): the stream's own source, a
// simulator (it reads no file), or a recording of the data directory, `replay:NAME?keys` with
// NAME resolved there (DataDir::ExistingFilePath). Anything else, a file elsewhere or another
// device, is InvalidArgument: a client must not make the daemon read what the operator did not
// give it (a crafted HDF5 file can hang the library, docs/fuzzing.md).
absl::StatusOr<std::string> ClientCalibrationSource(const std::string& uri,
                                                    const std::string& stream_uri,
                                                    const DataDir* data_dir) {
  if (uri == stream_uri || absl::StartsWith(uri, "sim:")) return uri;
  constexpr absl::string_view kReplay = "replay:";
  if (absl::StartsWith(uri, kReplay)) {
    const size_t query = uri.find('?');
    const std::string name =
        uri.substr(kReplay.size(), query == std::string::npos ? std::string::npos
                                                              : query - kReplay.size());
    if (data_dir == nullptr) {
      return absl::FailedPreconditionError(
          "source_uri: a replay must be in the data directory, and this daemon has none");
    }
    absl::StatusOr<std::string> path = data_dir->ExistingFilePath("source_uri", name);
    if (!path.ok()) return path.status();
    return absl::StrCat(kReplay, *path, query == std::string::npos ? "" : uri.substr(query));
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "source_uri = \"", uri, "\": a client may name the stream's source (", stream_uri,
      "), a simulator (sim:...) or a recording in the data directory (replay:NAME)"));
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Pipeline internals

struct Pipeline::Impl {
  explicit Impl(PipelineOptions o)
      : options(std::move(o)), cycle_queue(options.cycle_queue_frames) {}

  void Log(const std::string& line) {
    if (options.log) options.log(line);
  }

  // Source thread ------------------------------------------------------------------------------
  void SourceLoop();
  bool OpenSourceLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  void CloseSourceLocked(const std::string& reason) ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());
  // Why a recording cannot begin now: the source's state.
  std::string NoFramesToRecord();
  void Announce(SourceState state);
  void PushCycle(CycleItem item);
  void SleepInterruptibly(absl::Duration duration);
  // Copies the open source's counters into the stats (the source thread's, like Next).
  void RefreshSourceCounters() ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex());

  // Reconstruction thread ----------------------------------------------------------------------
  void ReconstructLoop();
  void Reconstruct(CycleItem& item);
  void Publish(std::shared_ptr<const PublishedFrame> frame);
  // The last frame with images Publish sent (the reconstruction thread's alone).
  std::shared_ptr<const PublishedFrame> newest_frame;
  ProductNeeds CurrentNeeds();

  PipelineOptions options;
  std::atomic<bool> stopping{false};
  std::thread source_thread, reconstruct_thread;
  std::atomic<bool> started{false};

  // Source, assembler and recorder: source thread, under Hdf5Mutex().
  std::unique_ptr<CaptureSource> source;
  std::optional<CycleAssembler> assembler;
  std::shared_ptr<const AcquisitionSchedule> source_schedule;
  uint64_t source_frames_lost = 0;        // DataLoss from the source
  uint64_t assembler_dropped_before = 0;  // by assemblers of sources closed since

  // Reconstruction thread only (made at Create, with the camera).
  std::unique_ptr<ReconstructionStage> reconstruction;

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
  FrameTimings timings ABSL_GUARDED_BY(mu);

  CycleQueue cycle_queue;  // between the threads
  Recorder recorder{[this](const std::string& line) { Log(line); }};
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
  recorder.Finish(absl::StrCat("stopped: ", reason));
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

void Pipeline::Impl::RefreshSourceCounters() {
  std::vector<SourceCounter> counters = source->Counters();
  if (counters.empty()) return;
  absl::MutexLock lock(&mu);
  stats.source_counters = std::move(counters);
}

void Pipeline::Impl::PushCycle(CycleItem item) {
  if (const int dropped = cycle_queue.Push(std::move(item)); dropped > 0) {
    absl::MutexLock lock(&mu);
    stats.cycles_dropped += static_cast<uint64_t>(dropped);
  }
}

std::string Pipeline::Impl::NoFramesToRecord() {
  absl::MutexLock lock(&mu);
  return absl::StrCat("the source ", source_uri, " is ", SourceStateName(state),
                      "; no frames to record");
}

void Pipeline::Impl::SourceLoop() {
  absl::Duration backoff = options.reopen_backoff_min;
  bool ended = false;
  RawFrame frame;
  while (!stopping.load()) {
    if (ended) {
      // A finished replay: nothing more to read; recordings and RPCs still work.
      {
        const std::string why = NoFramesToRecord();
        absl::MutexLock lock(&Hdf5Mutex());
        recorder.OnNoFrame(/*final=*/true, why);
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
          const std::string why = NoFramesToRecord();
          absl::MutexLock lock(&Hdf5Mutex());
          recorder.OnNoFrame(/*final=*/true, why);
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
        std::shared_ptr<const CalibrationTable> table;
        {
          absl::MutexLock lock(&mu);
          table = calibration;
        }
        recorder.OnFrame(frame, *source, std::move(table));
        absl::StatusOr<bool> added = assembler->Add(frame);
        complete = added.ok() && *added;
        // The source's own counters change by sequences, not frames: read them once a cycle.
        if (complete) RefreshSourceCounters();
        absl::MutexLock stats_lock(&mu);
        ++stats.raw_frames_in;
        stats.raw_frames_dropped = source_frames_lost + assembler_dropped_before +
                                   static_cast<uint64_t>(assembler->dropped_frames());
      } else {
        recorder.OnNoFrame(/*final=*/false, "");
        RefreshSourceCounters();  // what went wrong shows while no frame comes
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
  const std::string why = NoFramesToRecord();
  absl::MutexLock lock(&Hdf5Mutex());
  recorder.Finish("");
  recorder.OnNoFrame(/*final=*/true, why);  // a StartRecording still waiting fails now
  CloseSourceLocked("the daemon stopped");
}

ProductNeeds Pipeline::Impl::CurrentNeeds() {
  ProductSet products;
  ProductNeeds needs;
  absl::MutexLock lock(&mu);
  for (const auto& s : subscriptions) products |= s->request().products;
  needs = NeedsFor(products);
  for (const auto& s : subscriptions) {
    const ProductRequest& r = s->request();
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
  // Only the newest frame keeps its encodings (EncodedImages): the streams that were sharing
  // the previous one's have had their turn.
  if (!frame->announcement) {
    if (newest_frame != nullptr) newest_frame->encoded.Clear();
    newest_frame = frame;
  }
  std::vector<std::shared_ptr<Subscription>> targets;
  {
    absl::MutexLock lock(&mu);
    targets = subscriptions;
    if (!frame->announcement) {
      ++stats.frames_published;
      timings.AddPublished(frame->publish - frame->arrival);
    }
  }
  for (const auto& s : targets) s->Push(frame);
}

void Pipeline::Impl::Reconstruct(CycleItem& item) {
  ReconstructionInputs inputs;
  {
    absl::MutexLock lock(&mu);
    inputs.config = config;
    inputs.config_version = config_version;
    inputs.calibration = calibration;  // Calibrate may replace it meanwhile; this one stays valid
  }
  inputs.needs = CurrentNeeds();
  const absl::Time begin = absl::Now();
  absl::StatusOr<std::shared_ptr<const FrameProducts>> products =
      reconstruction->Run(item, inputs);
  if (!products.ok()) {
    Log(absl::StrCat("reconstruction: cycle refused: ", products.status().message()));
    absl::MutexLock lock(&mu);
    ++stats.cycles_refused;
    return;
  }
  auto frame = std::make_shared<PublishedFrame>();
  frame->sequence = (*products)->sequence;
  double first = item.frames.front().config.timestamp_s;
  for (const RawFrame& f : item.frames) first = std::min(first, f.config.timestamp_s);
  frame->capture_time_s = first;
  frame->arrival = item.arrival;
  frame->products = *products;
  frame->publish = absl::Now();
  {
    absl::MutexLock lock(&mu);
    latest = *products;
    ++stats.frames_reconstructed;
    stats.raw_frames_rejected += static_cast<uint64_t>(reconstruction->rejected_frames());
    timings.AddReconstructed(frame->publish - begin, frame->publish);
  }
  Publish(std::move(frame));
}

void Pipeline::Impl::ReconstructLoop() {
  absl::Time last_log = absl::Now();
  while (true) {
    std::optional<CycleItem> item = cycle_queue.Pop(kNextTimeout);
    if (stopping.load()) return;
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
      if (!s.source_counters.empty()) {
        std::vector<std::string> counters;
        for (const SourceCounter& c : s.source_counters) {
          if (c.value != 0) counters.push_back(absl::StrCat(c.name, " ", c.value));
        }
        Log(absl::StrCat("source counters: ",
                         counters.empty() ? "all 0" : absl::StrJoin(counters, ", ")));
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Pipeline

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
    impl.reconstruction = std::make_unique<ReconstructionStage>(impl.camera);
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
    impl.cycle_queue.set_wait_for_room((*opened)->capabilities().waits_for_consumer);
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
  impl_->cycle_queue.Close();
  impl_->recorder.Shutdown();
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
    absl::StatusOr<std::string> uri = SourceUriWithTakes(impl_->source_uri, config.takes);
    if (absl::IsFailedPrecondition(uri.status())) {
      return absl::FailedPreconditionError(absl::StrCat("takes (", impl_->config.takes,
                                                        " now): ", uri.status().message()));
    }
    if (!uri.ok()) return uri.status();
    impl_->source_uri = *std::move(uri);
    impl_->reopen_requested = true;
  }
  impl_->config = config;
  ++impl_->config_version;
  }
  impl_->Log(absl::StrCat("config: ", DescribeConfig(config)));
  return absl::OkStatus();
}

absl::StatusOr<CalibrationOutcome> Pipeline::Calibrate(
    const std::string& source_uri, int takes, const std::string& output_name, bool keep_current,
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
  if (schedule->options().DeliversDepth()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "Calibrate: ",
        schedule->options().MissingHarmonicsText(
            "a calibration (per-pixel factors of the moments against a Dirac at zero)"),
        "; ", stream_uri, " needs none"));
  }
  if (!uri.empty()) {
    absl::StatusOr<std::string> allowed =
        ClientCalibrationSource(uri, stream_uri, impl_->options.data_dir.get());
    if (!allowed.ok()) return allowed.status();
    uri = *std::move(allowed);
  }
  if (uri.empty()) {
    absl::StatusOr<std::string> derived = CalibrationSourceFor(stream_uri);
    if (!derived.ok()) {
      return absl::Status(derived.status().code(),
                          absl::StrCat("source_uri: required: ", derived.status().message()));
    }
    uri = *derived;
  }
  std::string output_path;
  if (!output_name.empty()) {
    absl::StatusOr<std::string> path = NewDataFile("output_path", output_name);
    if (!path.ok()) return path.status();
    // A calibration file holds a complex factor (two doubles) per pixel and harmonic.
    const uint64_t file_bytes = kRecordingOverheadBytes +
                                static_cast<uint64_t>(impl_->camera.geometry.pixel_count()) *
                                    static_cast<uint64_t>(schedule->order() + 1) * 16;
    if (absl::Status room = impl_->options.data_dir->CheckRoom(file_bytes); !room.ok()) {
      return room;
    }
    output_path = *std::move(path);
  }
  const SourceOpener open = impl_->options.open_source
                                ? impl_->options.open_source
                                : [](const std::string& u) { return transient::OpenSource(u); };
  absl::StatusOr<CalibrationOutcome> measured = MeasureLiveCalibration(
      {.source_uri = uri,
       .takes = takes,
       .output_path = output_path,
       .stream_uri = stream_uri,
       .stream_schedule = schedule->options(),
       .stream_geometry = impl_->camera.geometry},
      open, on_take, [this, &cancelled] {
        return impl_->stopping.load() || (cancelled && cancelled());
      });
  if (!measured.ok()) return measured.status();
  if (!keep_current) {
    const std::string origin =
        output_name.empty() ? absl::StrCat("measured from ", uri) : output_name;
    {
      absl::MutexLock lock(&impl_->mu);
      impl_->calibration = std::make_shared<const CalibrationTable>(measured->table);
      impl_->calibration_origin = origin;
    }
    impl_->Log(absl::StrCat("calibration: now ", origin));
  }
  return measured;
}

absl::StatusOr<std::string> Pipeline::NewDataFile(absl::string_view field,
                                                  absl::string_view name) const {
  if (impl_->options.data_dir == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat(field, ": this daemon writes no files (it has no data directory)"));
  }
  return impl_->options.data_dir->NewFilePath(field, name);
}

absl::StatusOr<RecordingStatus> Pipeline::StartRecording(const std::string& name,
                                                         uint64_t max_frames, int deflate_level) {
  {
    absl::MutexLock lock(&impl_->mu);
    if (const ScheduleOptions& schedule = impl_->schedule->options(); schedule.DeliversDepth()) {
      return absl::FailedPreconditionError(absl::StrCat(
          "StartRecording: ", schedule.MissingHarmonicsText("the capture file format"),
          " (transient-capture 1 holds modulated captures); ", impl_->source_uri,
          " is a recording or a device of its own"));
    }
  }
  absl::StatusOr<std::string> path = NewDataFile("path", name);
  if (!path.ok()) return path.status();
  RecordingTarget target{.name = name, .path = *std::move(path)};
  if (const DataDir& data_dir = *impl_->options.data_dir; data_dir.quota().max_bytes > 0 ||
                                                          data_dir.quota().max_files > 0) {
    const uint64_t frame_bytes =
        static_cast<uint64_t>(impl_->camera.geometry.pixel_count()) * sizeof(float);
    if (absl::Status room = data_dir.CheckRoom(kRecordingOverheadBytes + frame_bytes);
        !room.ok()) {
      return room;
    }
    target.byte_budget = data_dir.BytesLeft();
  }
  return impl_->recorder.Start(
      target, max_frames, deflate_level, impl_->started && !impl_->stopping.load(), [this] {
        absl::MutexLock lock(&impl_->mu);
        return absl::StrCat(impl_->source_uri, " (", SourceStateName(impl_->state), ")");
      });
}

absl::StatusOr<RecordingStatus> Pipeline::StopRecording() { return impl_->recorder.Stop(); }

PipelineStats Pipeline::Stats() const {
  absl::MutexLock lock(&impl_->mu);
  PipelineStats s = impl_->stats;
  s.state = impl_->state;
  impl_->timings.Fill(&s);
  for (const auto& sub : impl_->subscriptions) {
    s.subscribers.push_back(SubscriberSnapshot{.id = sub->id(),
                                               .peer = sub->peer(),
                                               .frames_sent = sub->frames_delivered(),
                                               .frames_missed = sub->frames_missed(),
                                               .products = sub->request().products});
  }
  s.recording = impl_->recorder.status();
  return s;
}

}  // namespace transient::service

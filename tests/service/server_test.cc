// transientd's gRPC service on a loopback port chosen at run time, with real clients: products,
// bad requests, many subscribers, disconnects, a lost source, recording and replay.
#include <grpcpp/grpcpp.h>

#include <atomic>
#include <csignal>
#include <fstream>
#include <map>
#include <memory>
#include <thread>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "tests/support/wait.h"
#include "transient/formats/capture_file.h"
#include "transient/drivers/simulator.h"
#include "transient/wire/grpc_status.h"
#include "transient/wire/image_codec.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/service/subscription.h"
#include "transient/v1/transient.grpc.pb.h"

namespace transient::service {
namespace {

using ::transient::wire::FromGrpcStatus;
using ::transient::wire::DecodeImage;

using ::testing::Each;
using ::testing::Gt;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::ChildProcess;
using ::transient::testing::ProcessResult;
using ::transient::testing::RunProcess;
using ::transient::testing::StatusIs;
using ::transient::testing::WaitForPortFile;
using ::transient::testing::WaitUntil;

using ::transient::service::testing::Connect;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::DataDirAt;
using ::transient::service::testing::ExpectSameAsLive;
using ::transient::service::testing::kSmallSim;
using ::transient::service::testing::RecordWhileStreaming;
using ::transient::service::testing::Request;
using ::transient::service::testing::WriteCapture;

// Reads up to `frames` frames with images; returns the status the stream ended with (OK when
// it was cut after `frames`).
absl::Status Receive(v1::Transient::Stub& stub, const v1::StreamRequest& request, int frames,
                     std::vector<v1::Frame>* out, absl::Duration deadline = absl::Seconds(30)) {
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + deadline));
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader = stub.StreamFrames(&context, request);
  v1::Frame frame;
  while (static_cast<int>(out->size()) < frames && reader->Read(&frame)) {
    out->push_back(frame);
  }
  if (static_cast<int>(out->size()) >= frames) {
    context.TryCancel();
    (void)reader->Finish();
    return absl::OkStatus();
  }
  return FromGrpcStatus(reader->Finish());
}

int ImagesOf(const std::vector<v1::Frame>& frames) {
  int n = 0;
  for (const v1::Frame& f : frames) n += f.images_size() > 0;
  return n;
}

TEST(Server, GetInfoDescribesSensorScheduleAndCalibration) {
  Daemon daemon(kSmallSim);
  grpc::ClientContext context;
  v1::Info info;
  ASSERT_TRUE(daemon.Stub()->GetInfo(&context, {}, &info).ok());
  EXPECT_EQ(info.camera().width(), 32u);
  EXPECT_EQ(info.camera().height(), 24u);
  EXPECT_GT(info.camera().fx(), 0.0);
  EXPECT_EQ(info.camera().distortion_size(), 5);
  EXPECT_EQ(info.source_uri(), kSmallSim);
  EXPECT_EQ(info.schedule().order(), 3u);
  EXPECT_DOUBLE_EQ(info.schedule().base_frequency_hz(), 23e6);
  EXPECT_EQ(info.schedule().raw_frames_per_frame(), 14u);
  EXPECT_EQ(info.calibration(), "none");
  EXPECT_EQ(info.products_size(), 10);
  EXPECT_EQ(info.version(), "test");
  EXPECT_NEAR(info.unambiguous_range_m(), 6.517, 1e-3);
}

TEST(EncodedImages, SharesAnEncodingUntilCleared) {
  EncodedImages cache;
  EXPECT_EQ(cache.Find("range|float16").get(), nullptr);
  auto first = std::make_shared<v1::Frame>();
  first->add_images()->set_name("range");
  EXPECT_EQ(cache.Insert("range|float16", first).get(), first.get());
  EXPECT_EQ(cache.Find("range|float16").get(), first.get());
  EXPECT_EQ(cache.Find("range|float32").get(), nullptr) << "another plan's key";
  // A stream that encoded the same meanwhile gets the stored one.
  EXPECT_EQ(cache.Insert("range|float16", std::make_shared<v1::Frame>()).get(), first.get());
  EXPECT_EQ(cache.hits(), 1);
  // Cleared (a newer frame was published): a stream holding it keeps it, the cache does not.
  std::weak_ptr<const v1::Frame> stored = first;
  cache.Clear();
  EXPECT_EQ(cache.Find("range|float16").get(), nullptr);
  EXPECT_FALSE(stored.expired()) << "still held by the stream";
  first.reset();
  EXPECT_TRUE(stored.expired()) << "the cache held no reference";
  // Nor does it keep what a late stream encodes for the frame.
  auto late = std::make_shared<v1::Frame>();
  EXPECT_EQ(cache.Insert("range|float16", late).get(), late.get());
  EXPECT_EQ(cache.Find("range|float16").get(), nullptr);
  EncodedImages racing;
  // Streams racing for the same key all end with the one stored.
  std::vector<std::shared_ptr<const v1::Frame>> got(8);
  std::vector<std::thread> threads;
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&, i] {
      std::shared_ptr<const v1::Frame> found = racing.Find("depth");
      got[i] = found != nullptr ? found : racing.Insert("depth", std::make_shared<v1::Frame>());
    });
  }
  for (std::thread& t : threads) t.join();
  for (const auto& g : got) EXPECT_EQ(g.get(), got[0].get());
}

TEST(Server, StreamsWithOnePlanShareItsEncodingAndAnotherPlanGetsItsOwn) {
  Daemon daemon(kSmallSim);
  v1::StreamRequest half = Request({v1::RANGE, v1::AMPLITUDE});
  half.set_encoding(v1::FLOAT16);
  v1::StreamRequest full = Request({v1::RANGE, v1::AMPLITUDE});
  std::vector<v1::Frame> a, b, c;
  std::thread second([&] { ASSERT_THAT(Receive(*daemon.Stub(), half, 6, &b), IsOk()); });
  std::thread third([&] { ASSERT_THAT(Receive(*daemon.Stub(), full, 6, &c), IsOk()); });
  ASSERT_THAT(Receive(*daemon.Stub(), half, 6, &a), IsOk());
  second.join();
  third.join();
  std::map<uint64_t, const v1::Frame*> by_sequence;
  for (const v1::Frame& f : b) {
    if (f.images_size() > 0) by_sequence[f.sequence()] = &f;
  }
  int same = 0;
  for (const v1::Frame& f : a) {
    auto it = by_sequence.find(f.sequence());
    if (f.images_size() == 0 || it == by_sequence.end()) continue;
    ++same;
    ASSERT_EQ(f.images_size(), it->second->images_size());
    for (int i = 0; i < f.images_size(); ++i) {
      EXPECT_EQ(f.images(i).SerializeAsString(), it->second->images(i).SerializeAsString());
      EXPECT_EQ(f.images(i).encoding(), "16FC1");
    }
  }
  EXPECT_GT(same, 0) << "the two streams shared no frame";
  for (const v1::Frame& f : c) {
    for (const v1::Image& image : f.images()) EXPECT_EQ(image.encoding(), "32FC1") << image.name();
  }
}

TEST(Server, StreamDeliversTheRequestedProductsInTheRoiAndEncoding) {
  Daemon daemon(kSmallSim);
  v1::StreamRequest request = Request({v1::RANGE, v1::DEPTH, v1::SLICES, v1::MOMENT_STATE,
                                       v1::FLAGS, v1::CUMULATIVE, v1::DIRECT_INDIRECT});
  request.mutable_roi()->set_x(4);
  request.mutable_roi()->set_y(2);
  request.mutable_roi()->set_width(20);
  request.mutable_roi()->set_height(10);
  request.set_encoding(v1::FLOAT16);
  request.set_compression(v1::ZSTD);
  request.mutable_slices()->set_bins(8);
  std::vector<v1::Frame> frames;
  ASSERT_THAT(Receive(*daemon.Stub(), request, 3, &frames), IsOk());
  ASSERT_EQ(ImagesOf(frames), 3);
  const v1::Frame& frame = frames.back();
  EXPECT_GT(frame.sequence(), frames.front().sequence());
  EXPECT_GT(frame.latency_s(), 0.0);
  EXPECT_GT(frame.publish_time().seconds(), 0);
  std::map<std::string, v1::Image> images;
  for (const v1::Image& image : frame.images()) images[image.name()] = image;
  // range, depth, 8 slices, 8 cumulative, flags, direct, indirect, m = 3: 4 c_real, 3 c_imag,
  // 4 q_real, 4 q_imag.
  EXPECT_EQ(images.size(), 2u + 8 + 8 + 1 + 2 + 15);
  for (const auto& [name, image] : images) {
    EXPECT_EQ(image.width(), 20u) << name;
    EXPECT_EQ(image.height(), 10u) << name;
    EXPECT_EQ(image.compression(), v1::ZSTD) << name;
    EXPECT_EQ(image.encoding(), name == "flags" ? "8UC1" : "16FC1") << name;
  }
  EXPECT_NEAR(images["slices/4"].time_of_flight_ns(), 4.0 / 8.0 / 23e6 * 1e9, 1e-9);
  absl::StatusOr<std::vector<float>> range = DecodeImage(images["range"]);
  absl::StatusOr<std::vector<float>> depth = DecodeImage(images["depth"]);
  ASSERT_THAT(range.status(), IsOk());
  ASSERT_THAT(depth.status(), IsOk());
  int finite = 0;
  for (size_t p = 0; p < range->size(); ++p) {
    if (!std::isfinite((*range)[p])) continue;
    ++finite;
    EXPECT_GT((*range)[p], 0.5f);
    EXPECT_LT((*range)[p], 7.0f);
    EXPECT_LE((*depth)[p], (*range)[p] * 1.001f);  // Z never exceeds the radial distance
  }
  EXPECT_GT(finite, 150);
}

TEST(Server, BadStreamRequestsAreInvalidArgumentWhileAnotherStreamGoesOn) {
  Daemon daemon(kSmallSim);
  std::atomic<int> received{0};
  std::atomic<bool> done{false};
  grpc::ClientContext good_context;
  auto good_stub = daemon.Stub();
  std::unique_ptr<grpc::ClientReader<v1::Frame>> good =
      good_stub->StreamFrames(&good_context, Request({v1::RANGE}));
  std::thread reader([&] {
    v1::Frame frame;
    while (!done && good->Read(&frame)) received += frame.images_size() > 0;
  });
  EXPECT_TRUE(WaitUntil([&] { return received.load() > 0; }));

  auto expect_invalid = [&](v1::StreamRequest request, const std::string& field) {
    std::vector<v1::Frame> frames;
    EXPECT_THAT(Receive(*daemon.Stub(), request, 1, &frames),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(field)))
        << request.ShortDebugString();
    EXPECT_TRUE(frames.empty());
  };
  expect_invalid(v1::StreamRequest(), "products");
  v1::StreamRequest unknown;
  unknown.add_products(static_cast<v1::Product>(42));
  expect_invalid(unknown, "products: unknown product 42");
  v1::StreamRequest roi = Request({v1::RANGE});
  roi.mutable_roi()->set_x(30);
  roi.mutable_roi()->set_width(8);
  roi.mutable_roi()->set_height(8);
  expect_invalid(roi, "roi");
  v1::StreamRequest zero_bins = Request({v1::SLICES});
  zero_bins.mutable_slices()->set_bins(0);
  expect_invalid(zero_bins, "slices.bins = 0");
  v1::StreamRequest huge_bins = Request({v1::SLICES});
  huge_bins.mutable_slices()->set_bins(1000000);
  expect_invalid(huge_bins, "slices.bins = 1000000");
  v1::StreamRequest too_many = Request({v1::CUMULATIVE});
  too_many.mutable_slices()->set_bins(4096);
  expect_invalid(too_many, "at most 1024");
  v1::StreamRequest mm_slices = Request({v1::SLICES});
  mm_slices.set_encoding(v1::UINT16_MM);
  expect_invalid(mm_slices, "UINT16_MM");
  v1::StreamRequest rate = Request({v1::RANGE});
  rate.set_max_rate_hz(-1.0);
  expect_invalid(rate, "max_rate_hz");
  v1::StreamRequest queue = Request({v1::RANGE});
  queue.set_queue_frames(1000);
  expect_invalid(queue, "queue_frames = 1000");
  v1::StreamRequest both = Request({v1::SLICES});
  both.mutable_slices()->set_bins(8);
  both.mutable_slices()->add_time_of_flight_ns(3.0);
  expect_invalid(both, "either time_of_flight_ns or bins");
  v1::StreamRequest index = Request({v1::SLICES});
  index.mutable_slices()->set_bins(8);
  index.mutable_slices()->add_bin_indices(8);
  expect_invalid(index, "slices.bin_indices: 8 is not below slices.bins = 8");
  v1::StreamRequest time = Request({v1::SLICES});
  time.mutable_slices()->add_time_of_flight_ns(-1.0);
  expect_invalid(time, "slices.time_of_flight_ns = -1");

  // The good stream kept receiving through all of that, and goes on.
  const int before = received.load();
  EXPECT_TRUE(WaitUntil([&] { return received.load() >= before + 3; })) << received.load();
  done = true;
  good_context.TryCancel();
  reader.join();
}

TEST(Server, MemoryLimitsOfStreamsAreRefusedNamingTheLimit) {
  // At 640x480, 54 slices and their cumulative images take 127 MiB per frame: 4 of them may
  // not wait for one client, and a third slice list passes the limit for all streams. The
  // limits apply when subscribing: the pipeline need not run (it would compute 250 MiB).
  Daemon daemon("sim:mirrors?width=640&height=480", /*start=*/false);
  auto stub = daemon.Stub();
  v1::StreamRequest big = Request({v1::SLICES, v1::CUMULATIVE});
  big.mutable_slices()->set_bins(54);
  std::vector<v1::Frame> frames;
  EXPECT_THAT(Receive(*stub, big, 1, &frames),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("queue_frames = 4")));
  big.set_queue_frames(1);
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::Frame>>> streams;
  for (int i = 0; i < 2; ++i) {
    if (i == 1) big.mutable_slices()->add_bin_indices(1);  // another list of 54 bins
    for (int n = 2; i == 1 && n < 54; ++n) big.mutable_slices()->add_bin_indices(n);
    if (i == 1) big.mutable_slices()->add_bin_indices(0);
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    streams.push_back(stub->StreamFrames(contexts.back().get(), big));
    ASSERT_TRUE(daemon.WaitForSubscribers(i + 1, absl::Seconds(20)));
    ASSERT_EQ(daemon.Stats().subscribers_size(), i + 1);
  }
  v1::StreamRequest third = Request({v1::SLICES});
  third.mutable_slices()->set_bins(8);
  third.set_queue_frames(1);
  frames.clear();
  EXPECT_THAT(Receive(*stub, third, 1, &frames),
              StatusIs(absl::StatusCode::kResourceExhausted, HasSubstr("at most 256 MiB")));
  // A stream using a list already computed costs nothing more: accepted.
  big.mutable_slices()->clear_bin_indices();
  grpc::ClientContext same_context;
  auto same = stub->StreamFrames(&same_context, big);
  EXPECT_TRUE(daemon.WaitForSubscribers(3, absl::Seconds(20)));
  EXPECT_EQ(daemon.Stats().subscribers_size(), 3);
  same_context.TryCancel();
  (void)same->Finish();
  for (auto& c : contexts) c->TryCancel();
  for (auto& s : streams) (void)s->Finish();
}

TEST(Server, StreamsBeyondTheLimitAreRefusedAsResourceExhausted) {
  Daemon daemon(kSmallSim, /*start=*/false);
  auto stub = daemon.Stub();
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::Frame>>> streams;
  for (int i = 0; i < kMaxSubscribers; ++i) {
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    streams.push_back(stub->StreamFrames(contexts.back().get(), Request({v1::RANGE})));
  }
  ASSERT_TRUE(daemon.WaitForSubscribers(kMaxSubscribers, absl::Seconds(30)));
  ASSERT_EQ(daemon.Stats().subscribers_size(), kMaxSubscribers);
  std::vector<v1::Frame> frames;
  EXPECT_THAT(Receive(*stub, Request({v1::RANGE}), 1, &frames),
              StatusIs(absl::StatusCode::kResourceExhausted, HasSubstr("at most 64 streams")));
  for (auto& c : contexts) c->TryCancel();
  for (auto& s : streams) (void)s->Finish();
}

TEST(Server, ClientThatDisconnectsMidStreamIsForgottenAndOthersGoOn) {
  Daemon daemon(kSmallSim);
  auto stub = daemon.Stub();
  grpc::ClientContext leaving;
  auto reader = stub->StreamFrames(&leaving, Request({v1::RANGE}));
  v1::Frame frame;
  ASSERT_TRUE(reader->Read(&frame));
  leaving.TryCancel();
  (void)reader->Finish();
  EXPECT_TRUE(daemon.WaitFor([&] { return daemon.Stats().subscribers_size() == 0; }));
  std::vector<v1::Frame> frames;
  EXPECT_THAT(Receive(*daemon.Stub(), Request({v1::RANGE}), 3, &frames), IsOk());
  EXPECT_EQ(ImagesOf(frames), 3);
}

// A fake device, because a camera cannot be unplugged in CI: it delivers a real simulator's
// frames, then reports the device lost (Unavailable); reopening fails twice, then works.
class VanishingSource : public CaptureSource {
 public:
  VanishingSource(std::unique_ptr<CaptureSource> inner, int frames_until_lost)
      : inner_(std::move(inner)), left_(frames_until_lost) {}
  const std::string& uri() const override { return inner_->uri(); }
  const CameraInfo& camera() const override { return inner_->camera(); }
  const AcquisitionSchedule& schedule() const override { return inner_->schedule(); }
  SourceCapabilities capabilities() const override { return inner_->capabilities(); }
  absl::Status Start() override { return inner_->Start(); }
  absl::Status Stop() override { return inner_->Stop(); }
  absl::Status Next(absl::Duration timeout, RawFrame* frame) override {
    if (left_ == 0) return absl::UnavailableError("test camera unplugged");
    --left_;
    return inner_->Next(timeout, frame);
  }

 private:
  std::unique_ptr<CaptureSource> inner_;
  int left_;
};

TEST(Server, LostSourceIsReopenedWhileClientsStayConnectedAndAreTold) {
  std::atomic<int> opens{0};
  PipelineOptions options{.source_uri = kSmallSim};
  options.reopen_backoff_min = absl::Milliseconds(10);
  options.open_source = [&](const std::string& uri)
      -> absl::StatusOr<std::unique_ptr<CaptureSource>> {
    const int n = opens++;
    // 0: Create's probe; 1: the first stream; 2, 3: the device is gone; then it is back.
    if (n == 2 || n == 3) return absl::UnavailableError("no such device");
    absl::StatusOr<std::unique_ptr<CaptureSource>> inner = OpenSource(uri);
    if (!inner.ok()) return inner.status();
    return std::make_unique<VanishingSource>(*std::move(inner), n == 1 ? 14 * 3 : 1 << 30);
  };
  Daemon daemon(std::move(options));
  auto stub = daemon.Stub();
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(30)));
  auto reader = stub->StreamFrames(&context, Request({v1::RANGE}));
  std::vector<v1::SourceState> announcements;
  int frames_after = 0;
  v1::Frame frame;
  while (frames_after < 3 && reader->Read(&frame)) {
    if (frame.images_size() == 0) {
      announcements.push_back(frame.state());
    } else if (!announcements.empty() && announcements.back() == v1::STREAMING) {
      ++frames_after;
    }
  }
  context.TryCancel();
  (void)reader->Finish();
  EXPECT_EQ(frames_after, 3);
  ASSERT_GE(announcements.size(), 2u);
  EXPECT_EQ(announcements.front(), v1::RECONNECTING);
  EXPECT_EQ(announcements.back(), v1::STREAMING);
  EXPECT_GE(opens.load(), 5);
  EXPECT_GE(daemon.Stats().source_reopens(), 1u);
}

TEST(Server, RecordingThroughTheRpcReplaysToTheSameMomentsBitForBit) {
  ScratchDirectory dir;
  const std::string path = dir.File("recorded.h5");
  // Video mode off: it fills outliers from the previous frame, which a replay starting at the
  // recording's first cycle does not have.
  PipelineOptions live{.source_uri = "sim:mirrors?width=24&height=16&seed=3"};
  live.config.video = false;
  live.data_dir = DataDirAt(dir);
  std::map<double, v1::Frame> live_frames;  // by capture time
  uint64_t recorded = 0;
  {
    Daemon daemon(live);
    recorded = RecordWhileStreaming(daemon, "recorded.h5", 5, &live_frames);
  }
  ASSERT_EQ(recorded, 5u * 14u);

  PipelineOptions replay{.source_uri = absl::StrCat("replay:", path, "?pace=fast")};
  replay.config.video = false;
  // The replay daemon uses no calibration unless given one: neither did the live one. It
  // starts only once the client has subscribed: a fast replay of 5 frames can otherwise end
  // before the stream opens (seen once on a loaded machine: no frame compared).
  Daemon daemon(replay, /*start=*/false);
  std::vector<v1::Frame> replayed;
  absl::Status end;
  std::thread receiver(
      [&] { end = Receive(*daemon.Stub(), Request({v1::MOMENT_STATE}), 1000, &replayed); });
  EXPECT_TRUE(daemon.WaitForSubscribers(1));
  daemon.pipeline().Start();
  receiver.join();
  EXPECT_THAT(end, StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("ended")));
  const int compared = ExpectSameAsLive(replayed, live_frames);
  EXPECT_GE(compared, 1);
}

TEST(Server, EndOfAReplayEndsNewStreamsWithOutOfRange) {
  ScratchDirectory dir;
  const std::string path = dir.File("short.h5");
  ASSERT_NO_FATAL_FAILURE(
      WriteCapture("sim:mirrors?width=16&height=12&pace=fast&frames=2", path));
  Daemon daemon(absl::StrCat("replay:", path, "?pace=fast"));
  // The end is announced once both recorded frames have been reconstructed.
  EXPECT_TRUE(daemon.WaitFor([&] {
    return daemon.pipeline().state() == SourceState::kEnded &&
           daemon.Stats().frames_reconstructed() >= 2;
  }));
  std::vector<v1::Frame> frames;
  EXPECT_THAT(Receive(*daemon.Stub(), Request({v1::RANGE}), 1, &frames),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("has ended")));
  EXPECT_EQ(daemon.Stats().frames_reconstructed(), 2u) << daemon.Stats().DebugString();
}

TEST(Server, GetPixelGivesCurvesAndReturnsAndRefusesBadPixels) {
  Daemon daemon(kSmallSim);
  auto stub = daemon.Stub();
  std::vector<v1::Frame> frames;
  ASSERT_THAT(Receive(*stub, Request({v1::RANGE}), 1, &frames), IsOk());
  v1::GetPixelRequest request;
  request.set_x(16);
  request.set_y(12);
  request.set_bins(128);
  v1::Pixel pixel;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub->GetPixel(&context, request, &pixel).ok());
  }
  EXPECT_EQ(pixel.density_size(), 128);
  EXPECT_EQ(pixel.cumulative_size(), 128);
  EXPECT_EQ(pixel.time_of_flight_ns_size(), 128);
  EXPECT_THAT(std::vector<double>(pixel.lower().begin(), pixel.lower().end()),
              Each(::testing::Ge(-1e-6)));
  for (int n = 0; n < 128; ++n) EXPECT_LE(pixel.lower(n), pixel.upper(n) + 1e-6);
  EXPECT_GE(pixel.returns_size(), 1);
  EXPECT_GT(pixel.c0(), 0.0);
  EXPECT_GT(pixel.range_m(), 0.5);

  auto refused = [&](uint32_t x, uint32_t y, uint32_t bins, double r, const std::string& what) {
    v1::GetPixelRequest bad;
    bad.set_x(x);
    bad.set_y(y);
    bad.set_bins(bins);
    bad.set_bounds_r(r);
    grpc::ClientContext context;
    v1::Pixel ignored;
    grpc::Status status = stub->GetPixel(&context, bad, &ignored);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << what;
    EXPECT_THAT(status.error_message(), HasSubstr(what));
  };
  refused(32, 0, 0, 0, "outside the 32x24 sensor");
  refused(0, 24, 0, 0, "outside");
  refused(0, 0, 70000, 0, "bins = 70000");
  refused(0, 0, 0, 1.5, "bounds_r = 1.5");
}

TEST(Server, SetConfigRefusesAnInvalidFieldAndChangesNothing) {
  Daemon daemon(kSmallSim);
  auto stub = daemon.Stub();
  v1::Config before;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub->GetConfig(&context, {}, &before).ok());
  }
  EXPECT_EQ(before.range_method(), v1::MESE);
  auto refused = [&](const v1::Config& update, const std::string& field) {
    grpc::ClientContext context;
    v1::Config out;
    grpc::Status status = stub->SetConfig(&context, update, &out);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field;
    EXPECT_THAT(status.error_message(), HasSubstr(field));
  };
  v1::Config bad;
  bad.set_threshold(0.3);  // valid, but in the same update as an invalid field
  bad.set_bias_epsilon(0.0);
  refused(bad, "bias_epsilon");
  v1::Config bad_sigma;
  bad_sigma.set_smoothing_sigma_px(-1);
  refused(bad_sigma, "smoothing_sigma_px");
  v1::Config bad_takes;
  bad_takes.set_takes(0);
  refused(bad_takes, "takes");
  v1::Config bad_method;
  bad_method.set_range_method(v1::METHOD_UNSPECIFIED);
  refused(bad_method, "range_method");
  v1::Config after;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub->GetConfig(&context, {}, &after).ok());
  }
  EXPECT_EQ(after.SerializeAsString(), before.SerializeAsString());

  v1::Config good;
  good.set_range_method(v1::PISARENKO);
  good.set_takes(2);
  v1::Config applied;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub->SetConfig(&context, good, &applied).ok());
  }
  EXPECT_EQ(applied.range_method(), v1::PISARENKO);
  EXPECT_EQ(applied.takes(), 2u);
  EXPECT_DOUBLE_EQ(applied.threshold(), before.threshold());
  // Two takes per frame now: the simulator was reopened with them and frames still come.
  std::vector<v1::Frame> frames;
  ASSERT_THAT(Receive(*stub, Request({v1::RANGE}), 2, &frames), IsOk());
  grpc::ClientContext context;
  v1::Info info;
  ASSERT_TRUE(stub->GetInfo(&context, {}, &info).ok());
  EXPECT_EQ(info.schedule().takes(), 2u);
  EXPECT_THAT(info.source_uri(), HasSubstr("takes=2"));
}

TEST(Server, CalibrateStreamsProgressThenTheAppliedResult) {
  Daemon daemon(kSmallSim);
  auto stub = daemon.Stub();
  v1::CalibrateRequest request;
  request.set_takes(4);
  request.set_output_path("calibration.h5");
  grpc::ClientContext context;
  auto reader = stub->Calibrate(&context, request);
  std::vector<v1::CalibrateProgress> messages;
  v1::CalibrateProgress message;
  while (reader->Read(&message)) messages.push_back(message);
  grpc::Status status = reader->Finish();
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(messages.size(), 5u);
  EXPECT_EQ(messages[0].done(), 1u);
  EXPECT_EQ(messages[0].total(), 4u);
  EXPECT_FALSE(messages[0].has_result());
  ASSERT_TRUE(messages.back().has_result());
  EXPECT_TRUE(messages.back().result().applied());
  EXPECT_EQ(messages.back().result().pixels(), 32u * 24u);
  EXPECT_GT(messages.back().result().usable_pixels(), 32u * 24u * 9 / 10);
  EXPECT_EQ(messages.back().result().output_path(), "calibration.h5");
  EXPECT_TRUE(std::filesystem::exists(daemon.DataFile("calibration.h5")));
  EXPECT_EQ(daemon.pipeline().calibration_origin(), "calibration.h5");

  // The same path again is refused: a calibration never replaces a file.
  grpc::ClientContext again_context;
  auto again = stub->Calibrate(&again_context, request);
  while (again->Read(&message)) {
  }
  EXPECT_EQ(again->Finish().error_code(), grpc::StatusCode::ALREADY_EXISTS);
}

TEST(Server, RecordingRequestsAreCheckedAndStopWithoutRecordingIsRefused) {
  Daemon daemon(kSmallSim);
  auto stub = daemon.Stub();
  {
    grpc::ClientContext context;
    v1::Recording out;
    EXPECT_EQ(stub->StopRecording(&context, {}, &out).error_code(),
              grpc::StatusCode::FAILED_PRECONDITION);
  }
  std::ofstream(daemon.DataFile("taken.h5")) << "x";
  v1::StartRecordingRequest exists;
  exists.set_path("taken.h5");
  v1::StartRecordingRequest deflate;
  deflate.set_path("new.h5");
  deflate.set_deflate_level(12);
  v1::StartRecordingRequest nowhere;
  nowhere.set_path("no/such/dir/x.h5");
  for (const auto& [request, code] :
       std::vector<std::pair<v1::StartRecordingRequest, grpc::StatusCode>>{
           {exists, grpc::StatusCode::ALREADY_EXISTS},
           {deflate, grpc::StatusCode::INVALID_ARGUMENT},
           {v1::StartRecordingRequest(), grpc::StatusCode::INVALID_ARGUMENT}}) {
    grpc::ClientContext context;
    v1::Recording out;
    EXPECT_EQ(stub->StartRecording(&context, request, &out).error_code(), code)
        << request.ShortDebugString();
  }
  grpc::ClientContext context;
  v1::Recording out;
  grpc::Status status = stub->StartRecording(&context, nowhere, &out);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(status.error_message(), HasSubstr("no directory \"no\""));
  // The stream is unaffected.
  std::vector<v1::Frame> frames;
  EXPECT_THAT(Receive(*stub, Request({v1::RANGE}), 2, &frames), IsOk());
}

#ifdef TRANSIENTD_BINARY

TEST(TransientdBinary, BadOptionsExitTwoNamingTheProblem) {
  ScratchDirectory dir;
  const std::string config = dir.File("bad.conf");
  std::ofstream(config) << "# reconstruction\nthreshold = 0.2\nbias_epsilon = lots\n";
  const std::string unknown = dir.File("unknown.conf");
  std::ofstream(unknown) << "colour = red\n";
  const std::string range = dir.File("range.conf");
  std::ofstream(range) << "threshold = 3\n";
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--config", config}, "bad.conf:3: bias_epsilon = lots: expected a number"},
      {{"--config", unknown}, "unknown key 'colour'"},
      {{"--config", range}, "threshold = 3"},
      {{"--config", dir.File("missing.conf")}, "missing.conf: cannot be read"},
      {{"--source", "sim:nowhere", "--uncalibrated"}, "nowhere"},
      {{"--source", "replay:" + dir.File("none.h5")}, "none.h5"},
      {{"--source", "usb:0"}, "'usb:0' is not a Kinect v2 URI"},
      {{"--source", "gige:0"}, "unknown source 'gige:0'"},
      {{"--calibration", dir.File("none.h5")}, "none.h5"},
      {{"--uncalibrated", "--calibration", "x.h5"}, "exclude each other"},
      {{"--uncalibrated", "--source", "sim:mirrors?width=16&height=12", "--listen",
        "256.1.1.1:1", "--insecure"},
       "cannot listen on 256.1.1.1:1"},
      {{"--uncalibrated", "--listen", "256.1.1.1:1"}, "serves other machines"},
      {{"--uncalibrated", "--data-dir", "/dev/null"}, "--data-dir: data directory /dev/null"},
  };
  for (const auto& [args, message] : cases) {
    std::vector<std::string> argv = {TRANSIENTD_BINARY};
    argv.insert(argv.end(), args.begin(), args.end());
    const ProcessResult result = RunProcess(argv);
    EXPECT_EQ(result.exit_code, 2) << args.front() << "\n" << result.err;
    EXPECT_THAT(result.err, HasSubstr(message)) << args.front();
  }
}

// The real binary: SIGTERM during a recording closes the file (it reopens with every frame
// written) and exits 0.
TEST(TransientdBinary, SigtermDuringARecordingClosesTheFileAndExitsZero) {
  ScratchDirectory dir;
  const std::string port_file = dir.File("port");
  const std::string capture = dir.File("capture.h5");
  ChildProcess daemon({TRANSIENTD_BINARY, "--source", "sim:mirrors?width=32&height=24", "--listen",
                       "127.0.0.1:0", "--port-file", port_file, "--uncalibrated", "--data-dir",
                       dir.path().string()},
                      dir.File("transientd.log"));
  ASSERT_TRUE(daemon.started());
  const int port = WaitForPortFile(port_file);
  ASSERT_GT(port, 0) << "transientd did not write its port";
  auto stub = Connect(port);
  {
    grpc::ClientContext context;
    v1::StartRecordingRequest start;
    start.set_path("capture.h5");
    v1::Recording out;
    grpc::Status status = stub->StartRecording(&context, start, &out);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  // Until the first flush (at most a second after the first frame) has made frames durable.
  uint64_t flushed = 0;
  EXPECT_TRUE(WaitUntil([&] {
    grpc::ClientContext context;
    v1::Stats stats;
    if (!stub->GetStats(&context, {}, &stats).ok()) return false;
    flushed = stats.recording().flushed_frames();
    return flushed > 0;
  }));
  ASSERT_TRUE(daemon.Signal(SIGTERM));
  EXPECT_EQ(daemon.Wait(), 0);
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(capture);
  ASSERT_THAT(reader.status(), IsOk());
  EXPECT_GE(static_cast<uint64_t>(reader->frames()), flushed);
  EXPECT_GT(reader->frames(), 14);
  RawFrame frame;
  EXPECT_THAT(reader->Read(reader->frames() - 1, &frame), IsOk());
}
#endif

}  // namespace
}  // namespace transient::service

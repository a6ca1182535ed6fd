// Reconstruction workers sharing a camera's frames through NATS JetStream: a real nats-server,
// a real daemon on the simulator publishing MOMENT_STATE, workers of the client library.
#include "transient/client/nats_worker.h"

#include <atomic>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/nats_server.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "tests/support/wait.h"
#include "transient/client/nats_stream.h"
#include "transient/service/nats_publisher.h"

namespace transient::client {
namespace {

using ::transient::service::NatsPublisher;
using ::transient::service::NatsPublishOptions;
using ::transient::service::testing::Daemon;
using ::transient::testing::IsOk;
using ::transient::testing::NatsServer;
using ::transient::testing::WaitUntil;

// 48x36 at m = 3: a MOMENT_STATE frame (104 KB) fits one message.
constexpr char kCamera[] = "sim:mirrors?width=48&height=36";

NatsWorkerOptions WorkerFor(const NatsServer& server) {
  NatsWorkerOptions options;
  options.connect.servers = server.url();
  options.camera = "lab";
  options.products = {v1::SLICES};
  options.bins = 16;
  options.ack_wait = absl::Seconds(1);
  return options;
}

std::unique_ptr<NatsPublisher> StartPublisher(Daemon& daemon, const NatsServer& server) {
  NatsPublishOptions options;
  options.connect.servers = server.url();
  options.camera = "lab";
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher =
      NatsPublisher::Start(&daemon.pipeline(), options);
  EXPECT_THAT(publisher.status(), IsOk());
  return publisher.ok() ? *std::move(publisher) : nullptr;
}

// The frame sequences on `product`'s subject from the stream's start, as far as it goes now.
std::vector<uint64_t> SequencesOn(const NatsServer& server, v1::Product product,
                                  std::vector<StreamFrame>* frames = nullptr) {
  NatsStreamOptions options;
  options.connect.servers = server.url();
  options.camera = "lab";
  options.product = product;
  options.start = NatsStreamOptions::Start::kAll;
  options.deadline = absl::Now() + absl::Seconds(1.5);  // then it only waits for new ones
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> stream = NatsFrameStream::Open(options);
  EXPECT_THAT(stream.status(), IsOk());
  std::vector<uint64_t> sequences;
  StreamFrame frame;
  while (stream.ok() && (*stream)->Next(&frame)) {
    EXPECT_EQ(frame.kind, StreamFrame::Kind::kImages) << frame.corruption;
    sequences.push_back(frame.sequence);
    if (frames != nullptr) frames->push_back(std::move(frame));
  }
  return sequences;
}

TEST(NatsWorker, TwoWorkersShareACamerasFramesExactlyOnce) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  std::unique_ptr<NatsPublisher> publisher = StartPublisher(daemon, server);
  ASSERT_NE(publisher, nullptr);
  absl::StatusOr<std::unique_ptr<NatsWorker>> first = NatsWorker::Open(WorkerFor(server));
  absl::StatusOr<std::unique_ptr<NatsWorker>> second = NatsWorker::Open(WorkerFor(server));
  ASSERT_THAT(first.status(), IsOk());
  ASSERT_THAT(second.status(), IsOk());

  // Both work until the publisher has sent 20 more frames, then drain what is left.
  const uint64_t published_at_start = publisher->Stats().frames_published;
  std::atomic<bool> publishing{true};
  auto work = [&](NatsWorker* worker) {
    int idle = 0;
    while (publishing.load() || idle < 3) {
      absl::StatusOr<bool> took = worker->ProcessOne(absl::Milliseconds(300));
      EXPECT_THAT(took.status(), IsOk());
      idle = took.ok() && *took ? 0 : idle + 1;
    }
  };
  std::thread a(work, first->get());
  std::thread b(work, second->get());
  EXPECT_TRUE(
      WaitUntil([&] { return publisher->Stats().frames_published >= published_at_start + 20; },
                absl::Seconds(60)));
  publisher->Stop();
  publishing = false;
  a.join();
  b.join();

  // Each worker took a share, and no frame was done twice.
  EXPECT_GT((*first)->done().size(), 0u);
  EXPECT_GT((*second)->done().size(), 0u);
  std::multiset<uint64_t> done((*first)->done().begin(), (*first)->done().end());
  done.insert((*second)->done().begin(), (*second)->done().end());
  EXPECT_EQ(std::set<uint64_t>(done.begin(), done.end()).size(), done.size())
      << "a frame was processed twice";
  // Every MOMENT_STATE frame from the first one a worker took is done: none was skipped.
  std::vector<uint64_t> expected;
  for (uint64_t s : SequencesOn(server, v1::MOMENT_STATE)) {
    if (s >= *done.begin()) expected.push_back(s);
  }
  EXPECT_EQ(std::vector<uint64_t>(done.begin(), done.end()), expected);
  // The products are in the stream once per frame, 16 density slices each.
  std::vector<StreamFrame> slices;
  std::vector<uint64_t> published = SequencesOn(server, v1::SLICES, &slices);
  std::sort(published.begin(), published.end());
  EXPECT_EQ(published, std::vector<uint64_t>(done.begin(), done.end()));
  ASSERT_FALSE(slices.empty());
  ASSERT_EQ(slices.front().images.size(), 16u);
  EXPECT_EQ(slices.front().images.front().product, v1::SLICES);
  EXPECT_EQ(slices.front().images.front().geometry.width, 48);
  EXPECT_EQ((*first)->counts().frames_refused + (*second)->counts().frames_refused, 0);
}

TEST(NatsWorker, AFrameHeldByAWorkerThatDiesGoesToAnother) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  std::unique_ptr<NatsPublisher> publisher = StartPublisher(daemon, server);
  ASSERT_NE(publisher, nullptr);
  absl::StatusOr<std::unique_ptr<NatsWorker>> survivor = NatsWorker::Open(WorkerFor(server));
  ASSERT_THAT(survivor.status(), IsOk());

  // The worker that dies: a JetStream client of the same group that takes a frame and is gone
  // (connection closed) before acknowledging it, as a worker killed mid-frame.
  uint64_t held = 0;
  {
    wire::NatsConnectOptions connect;
    connect.servers = server.url();
    absl::StatusOr<std::unique_ptr<wire::NatsConnection>> doomed =
        wire::NatsConnection::Open(connect, /*background=*/false);
    ASSERT_THAT(doomed.status(), IsOk());
    jsSubOptions bind;
    jsSubOptions_Init(&bind);
    bind.Stream = "TRANSIENT_lab";
    bind.Consumer = "workers";
    natsSubscription* sub = nullptr;
    jsErrCode code = static_cast<jsErrCode>(0);
    ASSERT_EQ(js_PullSubscribe(&sub, (*doomed)->jetstream(), "transient.lab.moment_state",
                               "workers", nullptr, &bind, &code),
              NATS_OK)
        << code;
    natsMsgList list{};
    ASSERT_EQ(natsSubscription_Fetch(&list, sub, 1, 10000, &code), NATS_OK);
    ASSERT_EQ(list.Count, 1);
    const char* sequence = nullptr;
    ASSERT_EQ(natsMsgHeader_Get(list.Msgs[0], "Transient-Sequence", &sequence), NATS_OK);
    held = std::stoull(sequence);
    natsMsgList_Destroy(&list);  // not acknowledged
    natsSubscription_Destroy(sub);
  }  // the connection closes: the worker is gone
  // The survivor gets it after the acknowledgement wait (1 s), among the newer frames.
  EXPECT_TRUE(WaitUntil(
      [&] {
        absl::StatusOr<bool> took = (*survivor)->ProcessOne(absl::Milliseconds(200));
        EXPECT_THAT(took.status(), IsOk());
        const std::vector<uint64_t>& done = (*survivor)->done();
        return std::find(done.begin(), done.end(), held) != done.end();
      },
      absl::Seconds(30)))
      << "frame " << held << " was not delivered again";
  EXPECT_GE((*survivor)->counts().frames_redelivered, 1);
}

TEST(NatsWorker, FramesInPartsAndBadOptionsAreRefused) {
  NatsServer server({}, "max_payload: 65536");  // a 104 KB frame travels in two parts
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  NatsWorkerOptions bad = WorkerFor(server);
  bad.products = {v1::RANGE};
  EXPECT_EQ(NatsWorker::Open(bad).status().code(), absl::StatusCode::kInvalidArgument);
  bad = WorkerFor(server);
  bad.group = "no.dots";
  EXPECT_EQ(NatsWorker::Open(bad).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(NatsWorker::Open(WorkerFor(server)).status().code(), absl::StatusCode::kNotFound);

  std::unique_ptr<NatsPublisher> publisher = StartPublisher(daemon, server);
  ASSERT_NE(publisher, nullptr);
  absl::StatusOr<std::unique_ptr<NatsWorker>> worker = NatsWorker::Open(WorkerFor(server));
  ASSERT_THAT(worker.status(), IsOk());
  EXPECT_TRUE(WaitUntil(
      [&] {
        EXPECT_THAT((*worker)->ProcessOne(absl::Milliseconds(200)).status(), IsOk());
        return (*worker)->counts().frames_refused >= 4;
      },
      absl::Seconds(30)));
  EXPECT_EQ((*worker)->counts().frames_done, 0);
}

// The tool's NATS commands against a daemon publishing float16 frames (one message each).
TEST(TransientTool, RecordsConsumesAndWorksOnACameraOverNats) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  NatsPublishOptions publish;
  publish.connect.servers = server.url();
  publish.camera = "lab";
  publish.request.set_encoding(v1::FLOAT16);
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher =
      NatsPublisher::Start(&daemon.pipeline(), publish);
  ASSERT_THAT(publisher.status(), IsOk());
  ::transient::testing::ScratchDirectory dir;
  auto run = [&](std::vector<std::string> argv) {
    argv.insert(argv.begin(), TRANSIENT_BINARY);
    return ::transient::testing::RunProcess(argv);
  };
  const std::vector<std::string> nats = {"--nats", server.url(), "--nats-camera", "lab"};
  auto with = [&](std::vector<std::string> argv, const std::vector<std::string>& more) {
    argv.insert(argv.end(), nats.begin(), nats.end());
    argv.insert(argv.end(), more.begin(), more.end());
    return argv;
  };
  // Moments into a file `transient reconstruct` reads.
  ::transient::testing::ProcessResult record =
      run(with({"record"}, {"--frames", "3", "--out", dir.File("moments.h5")}));
  ASSERT_EQ(record.exit_code, 0) << record.err;
  ::transient::testing::ProcessResult info = run({"info", dir.File("moments.h5")});
  EXPECT_THAT(info.out, ::testing::HasSubstr("3 frames of 48x36 px, m = 3"));
  // A worker's slices, received by the client.
  ::transient::testing::ProcessResult worker =
      run(with({"worker"}, {"--frames", "3", "--bins", "8"}));
  ASSERT_EQ(worker.exit_code, 0) << worker.err;
  EXPECT_THAT(worker.err, ::testing::HasSubstr("3 frames done"));
  ::transient::testing::ProcessResult slices =
      run(with({"client"}, {"--products", "slices", "--nats-start", "all", "--frames", "3", "--out",
                            dir.File("slices")}));
  ASSERT_EQ(slices.exit_code, 0) << slices.err;
  EXPECT_TRUE(std::filesystem::exists(dir.File("slices/slices/slice_007.png")));
  // The last seconds again: frames from 60 s ago (all of this stream), then live.
  ::transient::testing::ProcessResult again =
      run(with({"client"}, {"--products", "moment_state", "--nats-start", "ago:60", "--frames", "2",
                            "--out", dir.File("again")}));
  EXPECT_EQ(again.exit_code, 0) << again.err;
  // Bad options: exit 2 naming them.
  ::transient::testing::ProcessResult both =
      run(with({"record", "--source", kCamera}, {"--frames", "1", "--out", dir.File("x.h5")}));
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_THAT(both.err, ::testing::HasSubstr("--source or --nats"));
  ::transient::testing::ProcessResult start =
      run(with({"client"}, {"--products", "moment_state", "--nats-start", "yesterday", "--out",
                            dir.File("y")}));
  EXPECT_EQ(start.exit_code, 2);
  EXPECT_THAT(start.err, ::testing::HasSubstr("--nats-start 'yesterday'"));
  ::transient::testing::ProcessResult two =
      run(with({"client"}, {"--products", "range,slices", "--out", dir.File("z")}));
  EXPECT_EQ(two.exit_code, 2);
  EXPECT_THAT(two.err, ::testing::HasSubstr("exactly one"));
}

TEST(ParseNatsStart, TakesEveryStartAndRefusesTheRest) {
  NatsStreamOptions o;
  ASSERT_THAT(ParseNatsStart("--s", "seq:42", &o), IsOk());
  EXPECT_EQ(o.start, NatsStreamOptions::Start::kSequence);
  EXPECT_EQ(o.start_sequence, 42u);
  ASSERT_THAT(ParseNatsStart("--s", "time:2026-12-03T10:00:00Z", &o), IsOk());
  EXPECT_EQ(o.start, NatsStreamOptions::Start::kTime);
  EXPECT_EQ(o.start_time, absl::FromUnixSeconds(1796292000));
  ASSERT_THAT(ParseNatsStart("--s", "ago:60", &o), IsOk());
  EXPECT_EQ(o.start, NatsStreamOptions::Start::kTime);
  EXPECT_NEAR(absl::ToDoubleSeconds(absl::Now() - o.start_time), 60.0, 5.0);
  ASSERT_THAT(ParseNatsStart("--s", "all", &o), IsOk());
  EXPECT_EQ(o.start, NatsStreamOptions::Start::kAll);
  for (const char* bad : {"", "seq:0", "seq:-1", "ago:-5", "ago:nan", "time:yesterday", "old"}) {
    const absl::Status status = ParseNatsStart("--nats-start", bad, &o);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(status.message(), ::testing::HasSubstr("--nats-start")) << bad;
  }
}

TEST(SolvedFromMomentState, RefusesAnIncompleteState) {
  std::vector<DecodedImage> images;
  EXPECT_EQ(SolvedFromMomentState(images).status().code(), absl::StatusCode::kDataLoss);
  auto plane = [](wire::ImageKind kind, int j) {
    DecodedImage image;
    image.product = v1::MOMENT_STATE;
    image.kind = kind;
    image.index = j;
    image.name = wire::ImageName(kind, j);
    image.geometry = ImageGeometry{2, 1};
    image.values = {1.0f, std::nanf("")};
    return image;
  };
  for (int j = 0; j <= 1; ++j) {
    images.push_back(plane(wire::ImageKind::kCReal, j));
    if (j > 0) images.push_back(plane(wire::ImageKind::kCImag, j));
    images.push_back(plane(wire::ImageKind::kQReal, j));
  }
  // q_imag missing
  EXPECT_EQ(SolvedFromMomentState(images).status().code(), absl::StatusCode::kDataLoss);
  images.push_back(plane(wire::ImageKind::kQImag, 0));
  images.push_back(plane(wire::ImageKind::kQImag, 1));
  absl::StatusOr<SolvedImage> solved = SolvedFromMomentState(images);
  ASSERT_THAT(solved.status(), IsOk());
  EXPECT_EQ(solved->order, 1);
  EXPECT_TRUE(solved->valid(0));
  EXPECT_FALSE(solved->valid(1));                       // NaN q: invalid
  images.push_back(plane(wire::ImageKind::kQImag, 1));  // repeated
  EXPECT_EQ(SolvedFromMomentState(images).status().code(), absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace transient::client

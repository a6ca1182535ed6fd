// The daemon's NATS publisher and the client library's NATS consumer against a real
// nats-server (JetStream on, a scratch store, loopback ports chosen at run time), with a real
// daemon on the simulator in the test's process and real gRPC streams beside them.
#include "transient/service/nats_publisher.h"

#include <signal.h>
#include <sys/stat.h>

#include <atomic>
#include <fstream>
#include <map>
#include <thread>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/nats_server.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "tests/support/wait.h"
#include "transient/client/decoded_image.h"
#include "transient/client/nats_stream.h"

namespace transient::service {
namespace {

using ::transient::client::NatsFrameStream;
using ::transient::client::NatsStreamOptions;
using ::transient::client::StreamFrame;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::Request;
using ::transient::testing::IsOk;
using ::transient::testing::NatsServer;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::WaitUntil;

// 48x36 at m = 3: a MOMENT_STATE frame of 15 float planes is 104 KB, cut into parts by the
// test servers' max_payload below.
constexpr char kCamera[] = "sim:mirrors?width=48&height=36";

NatsPublishOptions PublishTo(const NatsServer& server, const std::string& camera = "lab") {
  NatsPublishOptions options;
  options.connect.servers = server.url();
  options.camera = camera;
  options.request.add_products(v1::MOMENT_STATE);
  return options;
}

NatsStreamOptions ConsumeFrom(const NatsServer& server, const std::string& camera = "lab") {
  NatsStreamOptions options;
  options.connect.servers = server.url();
  options.camera = camera;
  options.product = v1::MOMENT_STATE;
  options.deadline = absl::Now() + absl::Seconds(60);
  return options;
}

// The next kImages frame of `stream`, failing the test on anything else.
bool NextImages(NatsFrameStream& stream, StreamFrame* frame) {
  while (stream.Next(frame)) {
    EXPECT_NE(frame->kind, StreamFrame::Kind::kCorrupt) << frame->corruption;
    if (frame->kind == StreamFrame::Kind::kImages) return true;
  }
  return false;
}

bool SameValues(const std::vector<client::DecodedImage>& a,
                const std::vector<client::DecodedImage>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].name != b[i].name || a[i].values.size() != b[i].values.size() ||
        std::memcmp(a[i].values.data(), b[i].values.data(), a[i].values.size() * 4) != 0) {
      return false;
    }
  }
  return true;
}

TEST(NatsPublisher, FramesArriveAtTwoConsumersBitIdenticalToTheGrpcStream) {
  // A small max_payload makes every frame travel in two parts.
  NatsServer server({}, "max_payload: 65536");
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher =
      NatsPublisher::Start(&daemon.pipeline(), PublishTo(server));
  ASSERT_THAT(publisher.status(), IsOk());
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> first =
      NatsFrameStream::Open(ConsumeFrom(server));
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> second =
      NatsFrameStream::Open(ConsumeFrom(server));
  ASSERT_THAT(first.status(), IsOk());
  ASSERT_THAT(second.status(), IsOk());

  // The gRPC stream of the same request, read on its own thread.
  std::map<uint64_t, std::vector<client::DecodedImage>> grpc_frames;
  absl::Mutex mu;
  std::atomic<bool> done{false};
  std::thread grpc_reader([&] {
    grpc::ClientContext context;
    v1::StreamRequest request = Request({v1::MOMENT_STATE});
    request.set_queue_frames(16);
    auto reader = daemon.Stub()->StreamFrames(&context, request);
    v1::Frame frame;
    while (!done.load() && reader->Read(&frame)) {
      if (frame.images_size() == 0) continue;
      absl::StatusOr<std::vector<client::DecodedImage>> images = client::DecodeFrame(frame);
      EXPECT_THAT(images.status(), IsOk());
      absl::MutexLock lock(&mu);
      grpc_frames[frame.sequence()] = *std::move(images);
    }
    context.TryCancel();
  });

  constexpr int kFrames = 6;
  int compared = 0;
  for (NatsFrameStream* stream : {first->get(), second->get()}) {
    for (int n = 0; n < kFrames; ++n) {
      StreamFrame frame;
      ASSERT_TRUE(NextImages(*stream, &frame));
      EXPECT_EQ(frame.images.size(), 15u);  // c 0..3 (real, and imag from 1), q 0..3 (both)
      // The gRPC stream saw the same sequence (it subscribed first and keeps 16 frames).
      ASSERT_TRUE(WaitUntil([&] {
        absl::MutexLock lock(&mu);
        return grpc_frames.count(frame.sequence) > 0;
      })) << "frame " << frame.sequence << " never came over gRPC";
      absl::MutexLock lock(&mu);
      EXPECT_TRUE(SameValues(frame.images, grpc_frames[frame.sequence]))
          << "frame " << frame.sequence << " differs between NATS and gRPC";
      ++compared;
    }
  }
  done = true;
  grpc_reader.join();
  EXPECT_EQ(compared, 2 * kFrames);
  const NatsPublishStats stats = (*publisher)->Stats();
  EXPECT_TRUE(stats.connected);
  EXPECT_GE(stats.frames_published, static_cast<uint64_t>(kFrames));
  // Two parts per frame: 104 KB in messages of at most 64 KB.
  EXPECT_GE(stats.messages_published, 2 * stats.frames_published);
  EXPECT_EQ(stats.messages_failed, 0u) << stats.last_error;
  EXPECT_EQ((*first)->incomplete() + (*second)->incomplete(), 0);
}

TEST(NatsPublisher, ALateConsumerReplaysFromTheStartThenGoesLiveWithoutGapOrRepeat) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher =
      NatsPublisher::Start(&daemon.pipeline(), PublishTo(server));
  ASSERT_THAT(publisher.status(), IsOk());
  ASSERT_TRUE(WaitUntil([&] { return (*publisher)->Stats().messages_acknowledged >= 5; },
                        absl::Seconds(30)));
  const uint64_t published_before = (*publisher)->Stats().frames_published;

  NatsStreamOptions options = ConsumeFrom(server);
  options.start = NatsStreamOptions::Start::kAll;
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> late = NatsFrameStream::Open(options);
  ASSERT_THAT(late.status(), IsOk());
  // Every frame the publisher sent, from the first, then live ones: sequences only rise, and
  // each gap is one the publisher counted (Frame.missed), none the consumer lost.
  std::vector<uint64_t> sequences;
  uint64_t gaps_counted = 0;
  while (sequences.size() < published_before + 5) {
    StreamFrame frame;
    ASSERT_TRUE(NextImages(**late, &frame)) << "after " << sequences.size() << " frames";
    if (!sequences.empty()) {
      ASSERT_GT(frame.sequence, sequences.back()) << "a repeat or a frame out of order";
      EXPECT_EQ(frame.sequence - sequences.back() - 1, frame.missed)
          << "frames " << sequences.back() << " to " << frame.sequence;
    }
    gaps_counted += frame.missed;
    sequences.push_back(frame.sequence);
  }
  EXPECT_EQ((*late)->incomplete(), 0);
  EXPECT_EQ((*late)->stream_sequence(), sequences.size());  // one message per frame here
  EXPECT_EQ(gaps_counted, sequences.back() - sequences.front() + 1 - sequences.size());
}

TEST(NatsPublisher, TheServerKilledAndRestartedCostsOnlyTheNatsSide) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher =
      NatsPublisher::Start(&daemon.pipeline(), PublishTo(server));
  ASSERT_THAT(publisher.status(), IsOk());
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> consumer =
      NatsFrameStream::Open(ConsumeFrom(server));
  ASSERT_THAT(consumer.status(), IsOk());

  // A gRPC subscriber of RANGE the whole time.
  std::atomic<bool> done{false};
  std::atomic<int64_t> grpc_frames{0};
  std::atomic<uint64_t> grpc_missed{0};
  std::thread grpc_reader([&] {
    grpc::ClientContext context;
    v1::StreamRequest request = Request({v1::RANGE});
    request.set_queue_frames(64);
    auto reader = daemon.Stub()->StreamFrames(&context, request);
    v1::Frame frame;
    while (!done.load() && reader->Read(&frame)) {
      grpc_missed += frame.missed();
      if (frame.images_size() > 0) ++grpc_frames;
    }
    context.TryCancel();
  });

  StreamFrame frame;
  ASSERT_TRUE(NextImages(**consumer, &frame));
  server.Kill();
  ASSERT_TRUE(WaitUntil([&] { return (*publisher)->Stats().frames_dropped_disconnected >= 3; },
                        absl::Seconds(30)));
  const int64_t grpc_during_outage = grpc_frames.load();
  ASSERT_TRUE(server.Start());
  const uint64_t before_restart = frame.sequence;
  // The consumer resumes with frames published after the restart.
  uint64_t resumed = 0;
  while (NextImages(**consumer, &frame)) {
    if (frame.sequence > before_restart + 3) {
      resumed = frame.sequence;
      break;
    }
  }
  EXPECT_GT(resumed, 0u) << "the NATS consumer did not resume";
  done = true;
  grpc_reader.join();
  const NatsPublishStats stats = (*publisher)->Stats();
  EXPECT_GE(stats.reconnects, 1);
  EXPECT_GE(stats.disconnects, 1);
  EXPECT_GE(stats.frames_dropped_disconnected, 3u);
  // What the consumer learns: the frames dropped meanwhile are in Frame.missed.
  EXPECT_GE((*consumer)->counts().missed, 3u);
  // The gRPC client never noticed: frames throughout, none missed.
  EXPECT_GT(grpc_during_outage, 0);
  EXPECT_GT(grpc_frames.load(), grpc_during_outage);
  EXPECT_EQ(grpc_missed.load(), 0u);
}

TEST(NatsPublisher, WrongCredentialsAreRefused) {
  NatsServer server({"--user", "camera", "--pass", "right-password"});
  ASSERT_TRUE(server.running());
  ScratchDirectory dir;
  auto user_file = [&](const std::string& name, const std::string& line) {
    const std::string path = dir.File(name);
    std::ofstream(path) << line << "\n";
    ::chmod(path.c_str(), 0600);
    return path;
  };
  Daemon daemon(kCamera);
  NatsPublishOptions wrong = PublishTo(server);
  wrong.connect.user_file = user_file("wrong", "camera:wrong-password");
  EXPECT_EQ(NatsPublisher::Start(&daemon.pipeline(), wrong).status().code(),
            absl::StatusCode::kUnauthenticated);
  NatsPublishOptions none = PublishTo(server);
  EXPECT_EQ(NatsPublisher::Start(&daemon.pipeline(), none).status().code(),
            absl::StatusCode::kUnauthenticated);
  NatsStreamOptions consumer_wrong = ConsumeFrom(server);
  consumer_wrong.connect.user_file = wrong.connect.user_file;
  EXPECT_EQ(NatsFrameStream::Open(consumer_wrong).status().code(),
            absl::StatusCode::kUnauthenticated);
  // A password file others may read is refused before any connection.
  NatsPublishOptions readable = PublishTo(server);
  readable.connect.user_file = user_file("readable", "camera:right-password");
  ::chmod(readable.connect.user_file.c_str(), 0644);
  EXPECT_EQ(NatsPublisher::Start(&daemon.pipeline(), readable).status().code(),
            absl::StatusCode::kInvalidArgument);

  NatsPublishOptions right = PublishTo(server);
  right.connect.user_file = user_file("right", "camera:right-password");
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher =
      NatsPublisher::Start(&daemon.pipeline(), right);
  ASSERT_THAT(publisher.status(), IsOk());
  NatsStreamOptions consumer_right = ConsumeFrom(server);
  consumer_right.connect.user_file = right.connect.user_file;
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> consumer =
      NatsFrameStream::Open(consumer_right);
  ASSERT_THAT(consumer.status(), IsOk());
  StreamFrame frame;
  EXPECT_TRUE(NextImages(**consumer, &frame));
}

TEST(NatsPublisher, BadOptionsAreRefusedNamingWhatIsWrong) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  Daemon daemon(kCamera);
  NatsPublishOptions camera = PublishTo(server, "lab.1");
  absl::Status status = NatsPublisher::Start(&daemon.pipeline(), camera).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), ::testing::HasSubstr("'.'"));
  NatsPublishOptions url = PublishTo(server);
  url.connect.servers = "http://127.0.0.1:4222";
  EXPECT_EQ(NatsPublisher::Start(&daemon.pipeline(), url).status().code(),
            absl::StatusCode::kInvalidArgument);
  NatsPublishOptions product = PublishTo(server);
  product.request.add_products(v1::CONFIDENCE);  // not served on a schedule with every harmonic
  EXPECT_EQ(NatsPublisher::Start(&daemon.pipeline(), product).status().code(),
            absl::StatusCode::kFailedPrecondition);
  NatsPublishOptions replicas = PublishTo(server);
  replicas.replicas = 3;  // a single server cannot keep three copies
  EXPECT_FALSE(NatsPublisher::Start(&daemon.pipeline(), replicas).ok());
  // A consumer of a camera that no publisher ever created.
  NatsStreamOptions nobody = ConsumeFrom(server, "nobody");
  EXPECT_EQ(NatsFrameStream::Open(nobody).status().code(), absl::StatusCode::kNotFound);
  // No server at all: the consumer says so at once; a publisher waits for it in the background.
  NatsStreamOptions closed = ConsumeFrom(server);
  server.Kill();
  EXPECT_EQ(NatsFrameStream::Open(closed).status().code(), absl::StatusCode::kUnavailable);
  absl::StatusOr<std::unique_ptr<NatsPublisher>> waiting =
      NatsPublisher::Start(&daemon.pipeline(), PublishTo(server));
  ASSERT_THAT(waiting.status(), IsOk());
  EXPECT_FALSE((*waiting)->Stats().connected);
  ASSERT_TRUE(server.Start());
  EXPECT_TRUE(WaitUntil([&] { return (*waiting)->Stats().messages_acknowledged > 0; },
                        absl::Seconds(30)))
      << (*waiting)->Stats().last_error;
}

}  // namespace
}  // namespace transient::service

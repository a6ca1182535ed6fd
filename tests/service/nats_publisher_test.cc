// The daemon's NATS publisher and the client library's NATS consumer against a real
// nats-server (JetStream on, a scratch store, loopback ports chosen at run time), with a real
// daemon on the simulator in the test's process and real gRPC streams beside them.
#include "transient/service/nats_publisher.h"

#include <signal.h>
#include <sys/stat.h>

#include <atomic>
#include <fstream>
#include <map>
#include <optional>
#include <thread>

#include "absl/strings/str_join.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/certificates.h"
#include "tests/support/nats_server.h"
#include "tests/support/network.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "tests/support/wait.h"
#include "transient/client/decoded_image.h"
#include "transient/client/nats_stream.h"
#include "transient/service/reconstruction_config.h"

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
      })) << "frame "
          << frame.sequence << " never came over gRPC";
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
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> consumer = NatsFrameStream::Open(consumer_right);
  ASSERT_THAT(consumer.status(), IsOk());
  StreamFrame frame;
  EXPECT_TRUE(NextImages(**consumer, &frame));
}

TEST(NatsPublisher, MutualTlsAdmitsOnlyCertificatesOfTheServersCa) {
  ::transient::testing::Certificates certificates;
  ASSERT_TRUE(certificates.ok());
  NatsServer server({"--tls", "--tlscert", certificates.File("server", "pem"), "--tlskey",
                     certificates.File("server", "key"), "--tlsverify", "--tlscacert",
                     certificates.File("ca", "pem")});
  ASSERT_TRUE(server.running());
  auto secure = [&](wire::NatsConnectOptions* c, const std::string& ca, const std::string& who) {
    c->ca_file = certificates.File(ca, "pem");
    if (!who.empty()) {
      c->cert_file = certificates.File(who, "pem");
      c->key_file = certificates.File(who, "key");
    }
  };
  Daemon daemon(kCamera);
  NatsPublishOptions publish = PublishTo(server);
  secure(&publish.connect, "ca", "client");
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher =
      NatsPublisher::Start(&daemon.pipeline(), publish);
  ASSERT_THAT(publisher.status(), IsOk());
  NatsStreamOptions good = ConsumeFrom(server);
  secure(&good.connect, "ca", "client");
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> consumer = NatsFrameStream::Open(good);
  ASSERT_THAT(consumer.status(), IsOk());
  StreamFrame frame;
  EXPECT_TRUE(NextImages(**consumer, &frame));

  NatsStreamOptions stranger = ConsumeFrom(server);  // a certificate of another CA
  secure(&stranger.connect, "ca", "stranger");
  EXPECT_FALSE(NatsFrameStream::Open(stranger).ok());
  NatsStreamOptions anonymous = ConsumeFrom(server);  // no client certificate
  secure(&anonymous.connect, "ca", "");
  EXPECT_FALSE(NatsFrameStream::Open(anonymous).ok());
  NatsStreamOptions wrong_ca = ConsumeFrom(server);  // trusts another CA than the server's
  secure(&wrong_ca.connect, "other-ca", "client");
  EXPECT_FALSE(NatsFrameStream::Open(wrong_ca).ok());
  NatsStreamOptions plain = ConsumeFrom(server);  // no TLS at all
  EXPECT_FALSE(NatsFrameStream::Open(plain).ok());
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
  EXPECT_TRUE(
      WaitUntil([&] { return (*waiting)->Stats().messages_acknowledged > 0; }, absl::Seconds(30)))
      << (*waiting)->Stats().last_error;
}

TEST(Transientd, PublishesToNatsAndCountsItInGetStats) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  ScratchDirectory dir;
  const std::vector<std::string> base = {TRANSIENTD_BINARY, "--source",    kCamera,
                                         "--listen",        "127.0.0.1:0", "--data-dir",
                                         dir.File("data"),  "--publish",   server.url()};
  // Bad options: exit 2 naming them.
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--nats-products", "moment_state,nonsense"},
        std::vector<std::string>{"--nats-encoding", "float64"},
        std::vector<std::string>{"--nats-replicas", "7"},
        std::vector<std::string>{"--nats-user-file", dir.File("missing")}}) {
    std::vector<std::string> argv = base;
    argv.insert(argv.end(), bad.begin(), bad.end());
    const ::transient::testing::ProcessResult result = ::transient::testing::RunProcess(argv);
    EXPECT_EQ(result.exit_code, 2) << bad[0] << ": " << result.err;
    EXPECT_THAT(result.err,
                ::testing::HasSubstr(bad[0] == "--nats-replicas" ? "replicas" : bad[0]));
  }
  std::vector<std::string> argv = base;
  argv.insert(argv.end(),
              {"--port-file", dir.File("port"), "--nats-camera", "bin", "--nats-encoding",
               "float16", "--nats-zstd", "--nats-products", "moment_state,range"});
  ::transient::testing::ChildProcess daemon(argv, dir.File("log"));
  ASSERT_TRUE(daemon.started());
  const int port = ::transient::testing::WaitForPortFile(dir.File("port"));
  ASSERT_GT(port, 0);
  // A camera name that is not a subject token is refused before anything starts.
  std::vector<std::string> dotted = base;
  dotted.insert(dotted.end(), {"--nats-camera", "a.b"});
  const ::transient::testing::ProcessResult refused = ::transient::testing::RunProcess(dotted);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_THAT(refused.err, ::testing::HasSubstr("a.b"));
  NatsStreamOptions range = ConsumeFrom(server, "bin");
  range.product = v1::RANGE;
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> consumer = NatsFrameStream::Open(range);
  ASSERT_THAT(consumer.status(), IsOk());
  StreamFrame frame;
  ASSERT_TRUE(NextImages(**consumer, &frame));
  ASSERT_EQ(frame.images.size(), 1u);  // this subject carries RANGE only
  EXPECT_EQ(frame.images[0].product, v1::RANGE);
  v1::Stats stats;
  grpc::ClientContext context;
  ASSERT_TRUE(testing::Connect(port)->GetStats(&context, {}, &stats).ok());
  ASSERT_TRUE(stats.has_nats());
  EXPECT_EQ(stats.nats().camera(), "bin");
  EXPECT_TRUE(stats.nats().connected());
  EXPECT_GT(stats.nats().frames_published(), 0u);
  EXPECT_GE(stats.nats().messages_published(), 2 * stats.nats().frames_published() - 2);
  ASSERT_TRUE(daemon.Signal(SIGTERM));
  EXPECT_EQ(daemon.Wait(), 0);
}

TEST(Transientd, TakesItsNatsSettingsFromTheConfigFile) {
  NatsServer server;
  ASSERT_TRUE(server.running());
  ScratchDirectory dir;
  std::ofstream(dir.File("good.conf")) << "range_method = mese\npublish = " << server.url()
                                       << "\nnats_camera = conf\nnats_encoding = float16\n";
  std::ofstream(dir.File("bad.conf")) << "publish = " << server.url() << "\nnats_replicas = many\n";
  const std::vector<std::string> base = {TRANSIENTD_BINARY, "--source",    kCamera,
                                         "--listen",        "127.0.0.1:0", "--data-dir",
                                         dir.File("data")};
  std::vector<std::string> bad = base;
  bad.insert(bad.end(), {"--config", dir.File("bad.conf")});
  const ::transient::testing::ProcessResult refused = ::transient::testing::RunProcess(bad);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_THAT(refused.err, ::testing::HasSubstr("nats_replicas = many"));
  // Without a daemon's keys the parser still refuses them as unknown.
  ReconstructionConfig config;
  EXPECT_EQ(ParseConfig("publish = nats://h:1\n", "x.conf", &config).code(),
            absl::StatusCode::kInvalidArgument);

  std::vector<std::string> argv = base;
  argv.insert(argv.end(), {"--config", dir.File("good.conf"), "--port-file", dir.File("port")});
  ::transient::testing::ChildProcess daemon(argv, dir.File("log"));
  ASSERT_TRUE(daemon.started());
  ASSERT_GT(::transient::testing::WaitForPortFile(dir.File("port")), 0);
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> consumer =
      NatsFrameStream::Open(ConsumeFrom(server, "conf"));
  ASSERT_THAT(consumer.status(), IsOk());
  StreamFrame frame;
  ASSERT_TRUE(NextImages(**consumer, &frame));
  ASSERT_TRUE(daemon.Signal(SIGTERM));
  EXPECT_EQ(daemon.Wait(), 0);
}

// The stream's state as the cluster reports it: its leader's name and its message count.
struct StreamState {
  std::string leader;
  uint64_t messages = 0;
};
std::optional<StreamState> GetStreamState(wire::NatsConnection& connection,
                                          const std::string& camera) {
  jsStreamInfo* info = nullptr;
  jsErrCode code = static_cast<jsErrCode>(0);
  if (js_GetStreamInfo(&info, connection.jetstream(), wire::NatsStreamName(camera).c_str(), nullptr,
                       &code) != NATS_OK) {
    return std::nullopt;
  }
  StreamState state;
  state.messages = info->State.Msgs;
  if (info->Cluster != nullptr && info->Cluster->Leader != nullptr) {
    state.leader = info->Cluster->Leader;
  }
  jsStreamInfo_Destroy(info);
  return state;
}

TEST(NatsCluster, KillingTheStreamLeaderWhilePublishingLosesNoAcknowledgedFrame) {
  // Three servers on loopback routed to each other, one JetStream cluster.
  const int routes[3] = {::transient::testing::ClosedPort(), ::transient::testing::ClosedPort(),
                         ::transient::testing::ClosedPort()};
  std::vector<std::unique_ptr<NatsServer>> nodes;
  std::string urls;
  for (int n = 0; n < 3; ++n) {
    std::vector<std::string> peers;
    for (int k = 0; k < 3; ++k) {
      if (k != n) peers.push_back(absl::StrCat("nats://127.0.0.1:", routes[k]));
    }
    nodes.push_back(std::make_unique<NatsServer>(std::vector<std::string>{
        "-n", absl::StrCat("node", n), "--cluster_name", "transient", "--cluster",
        absl::StrCat("nats://127.0.0.1:", routes[n]), "--routes", absl::StrJoin(peers, ",")}));
    ASSERT_TRUE(nodes.back()->running());
    absl::StrAppend(&urls, n > 0 ? "," : "", nodes.back()->url());
  }
  Daemon daemon(kCamera);
  NatsPublishOptions options;
  options.connect.servers = urls;
  options.camera = "rig";
  options.replicas = 3;
  options.connect.timeout_ms = 1000;  // retries below come round sooner
  // The cluster elects its JetStream leaders in a few seconds: until then the stream cannot be
  // made.
  absl::StatusOr<std::unique_ptr<NatsPublisher>> publisher;
  ASSERT_TRUE(WaitUntil(
      [&] {
        publisher = NatsPublisher::Start(&daemon.pipeline(), options);
        return publisher.ok();
      },
      absl::Seconds(60)))
      << publisher.status();
  NatsStreamOptions live_options;
  live_options.connect.servers = urls;
  live_options.camera = "rig";
  live_options.deadline = absl::Now() + absl::Seconds(90);
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> live = NatsFrameStream::Open(live_options);
  ASSERT_THAT(live.status(), IsOk());
  StreamFrame frame;
  ASSERT_TRUE(NextImages(**live, &frame));
  ASSERT_TRUE(WaitUntil([&] { return (*publisher)->Stats().messages_acknowledged >= 10; },
                        absl::Seconds(30)));

  wire::NatsConnectOptions admin_options;
  admin_options.servers = urls;
  absl::StatusOr<std::unique_ptr<wire::NatsConnection>> admin =
      wire::NatsConnection::Open(admin_options, /*background=*/false);
  ASSERT_THAT(admin.status(), IsOk());
  const std::optional<StreamState> before = GetStreamState(**admin, "rig");
  ASSERT_TRUE(before.has_value());
  ASSERT_FALSE(before->leader.empty());
  const int leader = before->leader.back() - '0';
  ASSERT_TRUE(leader >= 0 && leader < 3) << before->leader;
  nodes[leader]->Kill();
  const uint64_t acknowledged_at_kill = (*publisher)->Stats().messages_acknowledged;

  // Publishing goes on through the other two: 20 more frames acknowledged.
  EXPECT_TRUE(WaitUntil(
      [&] { return (*publisher)->Stats().messages_acknowledged >= acknowledged_at_kill + 20; },
      absl::Seconds(60)))
      << (*publisher)->Stats().last_error;
  // The live consumer continues past the kill.
  const uint64_t seen = frame.sequence;
  bool continued = false;
  while (!continued && NextImages(**live, &frame)) continued = frame.sequence > seen + 20;
  EXPECT_TRUE(continued);
  (*publisher)->Stop();  // waits for the outstanding acknowledgements
  const NatsPublishStats stats = (*publisher)->Stats();

  // Every acknowledged message is in the stream: a consumer from the start reads at least as
  // many, frames in order, none corrupt.
  std::optional<StreamState> after;
  ASSERT_TRUE(WaitUntil([&] { return (after = GetStreamState(**admin, "rig")).has_value(); },
                        absl::Seconds(30)));
  EXPECT_GE(after->messages, stats.messages_acknowledged);
  NatsStreamOptions replay_options = live_options;
  replay_options.start = NatsStreamOptions::Start::kAll;
  replay_options.deadline = absl::Now() + absl::Seconds(60);
  replay_options.connect.timeout_ms = 1000;
  // A new consumer waits for the cluster to settle after the kill (its JetStream API may time
  // out while leaders are elected again).
  absl::StatusOr<std::unique_ptr<NatsFrameStream>> replay;
  ASSERT_TRUE(WaitUntil([&] { return (replay = NatsFrameStream::Open(replay_options)).ok(); },
                        absl::Seconds(60)))
      << replay.status();
  std::optional<uint64_t> last;  // the daemon's first frame is number 0, and it may be stored
  int64_t frames = 0;
  while ((*replay)->stream_sequence() < after->messages && NextImages(**replay, &frame)) {
    if (last.has_value()) EXPECT_GT(frame.sequence, *last);
    last = frame.sequence;
    ++frames;
  }
  EXPECT_EQ((*replay)->stream_sequence(), after->messages);
  EXPECT_GE(static_cast<uint64_t>(frames), stats.messages_acknowledged);  // a message a frame
  EXPECT_EQ((*replay)->counts().corrupt, 0);
}

}  // namespace
}  // namespace transient::service

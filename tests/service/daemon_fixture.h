// A real transientd in the test's process: a Pipeline on a source URI and its gRPC server on a
// loopback port chosen at run time. Shared by the service and the client tests.
#pragma once

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "gtest/gtest.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/wait.h"
#include "transient/client/decoded_image.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/source_registry.h"
#include "transient/formats/capture_file.h"
#include "transient/service/data_dir.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/v1/transient.grpc.pb.h"

namespace transient::service::testing {

// The small simulated camera of the daemon tests: 32x24, at its own pace (12.5 frames/s).
inline constexpr char kSmallSim[] = "sim:mirrors?width=32&height=24";

inline std::unique_ptr<v1::Transient::Stub> Connect(int port) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  auto channel = grpc::CreateCustomChannel(absl::StrCat("127.0.0.1:", port),
                                           grpc::InsecureChannelCredentials(), args);
  return v1::Transient::NewStub(channel);
}

// A stream request for `products`, every other field at its default.
inline v1::StreamRequest Request(std::initializer_list<v1::Product> products) {
  v1::StreamRequest request;
  for (v1::Product p : products) request.add_products(p);
  return request;
}

// A data directory without quota at `dir`, for a daemon whose files outlive it.
inline std::shared_ptr<const DataDir> DataDirAt(const ::transient::testing::ScratchDirectory& dir,
                                                DataQuota quota = {}) {
  absl::StatusOr<DataDir> data_dir = DataDir::Open(dir.path().string(), quota);
  EXPECT_TRUE(data_dir.ok()) << data_dir.status();
  return data_dir.ok() ? std::make_shared<const DataDir>(*std::move(data_dir)) : nullptr;
}

// A capture file at `path` of every raw frame of `uri` (a simulator with frames=N), for a replay
// or a Calibrate from one. Fails the test (ASSERT) when the source or the file fails.
inline void WriteCapture(const std::string& uri, const std::string& path) {
  using ::transient::testing::IsOk;
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(uri);
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  RawFrame frame;
  ASSERT_THAT((*source)->Next(absl::Seconds(5), &frame), IsOk());
  absl::StatusOr<CaptureWriter> writer =
      CaptureWriter::Create(path, (*source)->camera(), (*source)->schedule(),
                            {.saturation_level = frame.saturation_level});
  ASSERT_THAT(writer.status(), IsOk());
  do {
    ASSERT_THAT(writer->Append(frame), IsOk());
  } while ((*source)->Next(absl::Seconds(5), &frame).ok());
  ASSERT_THAT(writer->Close(), IsOk());
}

class Daemon {
 public:
  // start = false: the server answers, but no frame is ever produced until pipeline().Start().
  // Without options.data_dir, the daemon writes into a scratch directory of its own, removed
  // with it.
  // `access`: TLS and the checks of every call (ServerOptions::access); nullptr = none.
  explicit Daemon(PipelineOptions options, bool start = true,
                  std::shared_ptr<const Access> access = nullptr) {
    if (options.data_dir == nullptr) {
      own_data_ = std::make_unique<::transient::testing::ScratchDirectory>();
      options.data_dir = DataDirAt(*own_data_);
    }
    data_dir_ = options.data_dir;
    absl::StatusOr<std::unique_ptr<Pipeline>> pipeline = Pipeline::Create(std::move(options));
    EXPECT_TRUE(pipeline.ok()) << pipeline.status();
    if (!pipeline.ok()) return;
    pipeline_ = *std::move(pipeline);
    absl::StatusOr<std::unique_ptr<TransientServer>> server =
        TransientServer::Start(pipeline_.get(), {.listen = "127.0.0.1:0",
                                                 .version = "test",
                                                 .access = std::move(access)});
    EXPECT_TRUE(server.ok()) << server.status();
    if (!server.ok()) return;
    server_ = *std::move(server);
    if (start) pipeline_->Start();
  }
  explicit Daemon(const std::string& uri, bool start = true)
      : Daemon(PipelineOptions{.source_uri = uri}, start) {}
  ~Daemon() { Stop(); }

  void Stop() {
    if (pipeline_ != nullptr) pipeline_->Stop();
    if (server_ != nullptr) server_->Shutdown(absl::Seconds(2));
  }

  Pipeline& pipeline() { return *pipeline_; }
  // The path of `name` in the daemon's data directory.
  std::string DataFile(const std::string& name) const {
    return absl::StrCat(data_dir_->root(), "/", name);
  }
  std::string address() const { return absl::StrCat("127.0.0.1:", server_->port()); }
  int port() const { return server_->port(); }
  std::unique_ptr<v1::Transient::Stub> Stub() { return Connect(server_->port()); }

  v1::Stats Stats() {
    grpc::ClientContext context;
    v1::Stats stats;
    EXPECT_TRUE(Stub()->GetStats(&context, {}, &stats).ok());
    return stats;
  }

  // Waits until `condition` holds (tests/support/wait.h); false if it never did.
  bool WaitFor(const std::function<bool()>& condition, absl::Duration timeout = absl::Seconds(10)) {
    return ::transient::testing::WaitUntil(condition, timeout);
  }
  bool WaitForFirstFrame() {
    return WaitFor([this] { return pipeline_->Latest() != nullptr; });
  }
  bool WaitForSubscribers(size_t count, absl::Duration timeout = absl::Seconds(10)) {
    return WaitFor([this, count] { return pipeline_->Stats().subscribers.size() >= count; },
                   timeout);
  }

 private:
  std::unique_ptr<::transient::testing::ScratchDirectory> own_data_;  // outlives the pipeline
  std::shared_ptr<const DataDir> data_dir_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<TransientServer> server_;
};

// Streams MOMENT_STATE from `daemon`, starts a recording of `max_frames` transient frames into
// `name` (of its data directory) once the first frame has come, and keeps the live frames with
// images by capture time until the recording has ended by itself (and a few frames more, so
// that every recorded cycle has been published). The raw frames recorded; 0, with a test failure, when it went wrong.
inline uint64_t RecordWhileStreaming(Daemon& daemon, const std::string& name, int max_frames,
                                     std::map<double, v1::Frame>* live) {
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(60)));
  auto reader = daemon.Stub()->StreamFrames(&context, Request({v1::MOMENT_STATE}));
  v1::Frame frame;
  uint64_t recorded = 0;
  if (!reader->Read(&frame)) {
    ADD_FAILURE() << "no frame before the recording";
  } else {
    grpc::ClientContext start_context;
    v1::StartRecordingRequest start;
    start.set_path(name);
    start.set_max_frames(max_frames);
    v1::Recording recording;
    const grpc::Status status = daemon.Stub()->StartRecording(&start_context, start, &recording);
    EXPECT_TRUE(status.ok()) << status.error_message();
    EXPECT_TRUE(recording.active());
    while (status.ok() && reader->Read(&frame)) {
      if (frame.images_size() > 0) (*live)[frame.capture_time_s()] = frame;
      const v1::Stats stats = daemon.Stats();
      if (!stats.recording().active() && stats.recording().raw_frames() > 0) {
        recorded = stats.recording().raw_frames();
        EXPECT_EQ(stats.recording().error(), "");
        for (int i = 0; i < 3 && reader->Read(&frame); ++i) {
          if (frame.images_size() > 0) (*live)[frame.capture_time_s()] = frame;
        }
        break;
      }
    }
  }
  context.TryCancel();
  (void)reader->Finish();
  return recorded;
}

// Each replayed frame with images has the live frame of its capture time, and their images are
// equal byte for byte. The frames compared.
inline int ExpectSameAsLive(const std::vector<v1::Frame>& replayed,
                            const std::map<double, v1::Frame>& live) {
  int compared = 0;
  for (const v1::Frame& frame : replayed) {
    if (frame.images_size() == 0) continue;
    auto it = live.find(frame.capture_time_s());
    if (it == live.end()) {
      ADD_FAILURE() << "no live frame of the replayed capture time " << frame.capture_time_s();
      continue;
    }
    EXPECT_EQ(frame.images_size(), it->second.images_size());
    for (int i = 0; i < std::min(frame.images_size(), it->second.images_size()); ++i) {
      EXPECT_EQ(frame.images(i).name(), it->second.images(i).name());
      EXPECT_EQ(frame.images(i).data(), it->second.images(i).data())
          << frame.images(i).name() << " of the frame at " << frame.capture_time_s() << " s";
    }
    ++compared;
  }
  return compared;
}

// The first frame with images of a stream of `request`, undecoded; the stream's status when it
// ends first (a refused request).
inline absl::StatusOr<v1::Frame> FirstFrame(Daemon& daemon, const v1::StreamRequest& request) {
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(60)));
  auto reader = daemon.Stub()->StreamFrames(&context, request);
  v1::Frame frame;
  while (reader->Read(&frame)) {
    if (frame.images_size() == 0) continue;
    context.TryCancel();
    (void)reader->Finish();
    return frame;
  }
  const grpc::Status status = reader->Finish();
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()), status.error_message());
}

// Its images decoded and keyed by image name. Links transient_client.
inline absl::StatusOr<std::map<std::string, std::vector<float>>> FirstDecodedFrame(
    Daemon& daemon, const v1::StreamRequest& request) {
  absl::StatusOr<v1::Frame> frame = FirstFrame(daemon, request);
  if (!frame.ok()) return frame.status();
  absl::StatusOr<std::vector<client::DecodedImage>> images = client::DecodeFrame(*frame);
  if (!images.ok()) return images.status();
  std::map<std::string, std::vector<float>> out;
  for (client::DecodedImage& image : *images) out[image.name] = std::move(image.values);
  return out;
}

}  // namespace transient::service::testing

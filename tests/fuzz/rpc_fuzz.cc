// Requests from the network through the real daemon: a Pipeline on a small simulated camera
// and its gRPC server on a loopback port, started once. The first byte picks the RPC, the rest
// is its request message's bytes (the seeds are valid requests, tests/fuzz/make_seeds.cc).
// Recordings go to a scratch data directory with a quota of 64 files and are stopped at once;
// a stream is read for its first message only. Calibrate is left out: each call takes its
// takes of the camera (seconds). Property: every call returns a status (a crash, a sanitizer
// report or a hang is the finding); the daemon still answers GetInfo after every input.
#include <google/protobuf/stubs/logging.h>
#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "tests/fuzz/scratch_directory.h"
#include "transient/service/data_dir.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/v1/transient.grpc.pb.h"

namespace {

using transient::v1::Transient;

struct Daemon {
  std::unique_ptr<transient::service::Pipeline> pipeline;
  std::unique_ptr<transient::service::TransientServer> server;
  std::unique_ptr<Transient::Stub> stub;
};

Daemon& TheDaemon() {
  static Daemon* daemon = [] {
    // Removed at exit after the handler below, registered later, has stopped the daemon.
    const std::string root = transient::fuzz::ScratchDirectoryRemovedAtExit("transient-fuzz-rpc");
    absl::StatusOr<transient::service::DataDir> data =
        transient::service::DataDir::Open(root, {.max_bytes = 64 << 20, .max_files = 64});
    if (!data.ok()) std::abort();
    transient::service::PipelineOptions options{.source_uri =
                                                    "sim:mirrors?width=16&height=12&pace=fast"};
    options.data_dir = std::make_shared<const transient::service::DataDir>(*std::move(data));
    auto* made = new Daemon;
    absl::StatusOr<std::unique_ptr<transient::service::Pipeline>> pipeline =
        transient::service::Pipeline::Create(std::move(options));
    if (!pipeline.ok()) std::abort();
    made->pipeline = *std::move(pipeline);
    absl::StatusOr<std::unique_ptr<transient::service::TransientServer>> server =
        transient::service::TransientServer::Start(made->pipeline.get(),
                                                   {.listen = "127.0.0.1:0", .version = "fuzz"});
    if (!server.ok()) std::abort();
    made->server = *std::move(server);
    made->pipeline->Start();
    // Stopped before the process ends: the pipeline's threads must not run while the OpenMP
    // runtime shuts down (libomp asserted in __kmp_init_serial at a replay's exit).
    std::atexit([] {
      Daemon& running = TheDaemon();
      running.pipeline->Stop();
      running.server->Shutdown(absl::Seconds(1));
    });
    grpc::ChannelArguments arguments;
    arguments.SetMaxReceiveMessageSize(-1);
    made->stub = Transient::NewStub(
        grpc::CreateCustomChannel(absl::StrCat("127.0.0.1:", made->server->port()),
                                  grpc::InsecureChannelCredentials(), arguments));
    return made;
  }();
  return *daemon;
}

std::unique_ptr<grpc::ClientContext> Context() {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(10)));
  return context;
}

template <typename Request>
bool Parse(const uint8_t* data, size_t size, Request* request) {
  return request->ParseFromArray(data, static_cast<int>(size));
}

}  // namespace

// Protobuf logs every string field with invalid UTF-8 it parses: thousands of lines a second
// of fuzzing, for what the parse result already says.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  Daemon& daemon = TheDaemon();
  Transient::Stub& stub = *daemon.stub;
  const uint8_t rpc = data[0] % 6;
  ++data;
  --size;
  switch (rpc) {
    case 0: {
      transient::v1::StreamRequest request;
      if (!Parse(data, size, &request)) return 0;
      auto context = Context();
      auto reader = stub.StreamFrames(context.get(), request);
      transient::v1::Frame frame;
      (void)reader->Read(&frame);
      context->TryCancel();
      (void)reader->Finish();
      break;
    }
    case 1: {
      transient::v1::GetPixelRequest request;
      if (!Parse(data, size, &request)) return 0;
      transient::v1::Pixel pixel;
      (void)stub.GetPixel(Context().get(), request, &pixel);
      break;
    }
    case 2: {
      transient::v1::Config request;
      if (!Parse(data, size, &request)) return 0;
      // takes change the simulator's schedule; at most 4 keep it quick.
      if (request.has_takes() && request.takes() > 4) request.set_takes(4);
      transient::v1::Config config;
      (void)stub.SetConfig(Context().get(), request, &config);
      break;
    }
    case 3: {
      transient::v1::StartRecordingRequest request;
      if (!Parse(data, size, &request)) return 0;
      transient::v1::Recording recording;
      if (stub.StartRecording(Context().get(), request, &recording).ok()) {
        (void)stub.StopRecording(Context().get(), {}, &recording);
      }
      break;
    }
    default: {
      transient::v1::Stats stats;
      (void)stub.GetStats(Context().get(), {}, &stats);
      break;
    }
  }
  transient::v1::Info info;
  if (!stub.GetInfo(Context().get(), {}, &info).ok()) std::abort();
  return 0;
}

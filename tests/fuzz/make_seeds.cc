// Writes the seed corpora of the harnesses whose inputs are messages (tests/fuzz/corpus/):
// image_codec gets real frames of a daemon on a small simulated camera, one per product set,
// encoding and compression; rpc gets valid requests of each kind behind their selector byte.
//   transient_fuzz_make_seeds tests/fuzz/corpus
// Run again when the protocol changes; the seeds are committed.
#include <grpcpp/grpcpp.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/v1/transient.grpc.pb.h"

namespace v1 = transient::v1;

namespace {

void Write(const std::filesystem::path& path, const std::string& bytes) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const std::filesystem::path corpus = argv[1];
  absl::StatusOr<std::unique_ptr<transient::service::Pipeline>> pipeline =
      transient::service::Pipeline::Create(
          {.source_uri = "sim:mirrors?width=16&height=12&pace=fast"});
  if (!pipeline.ok()) return 1;
  absl::StatusOr<std::unique_ptr<transient::service::TransientServer>> server =
      transient::service::TransientServer::Start(pipeline->get(),
                                                 {.listen = "127.0.0.1:0", .version = "seeds"});
  if (!server.ok()) return 1;
  (*pipeline)->Start();
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(-1);
  auto stub = v1::Transient::NewStub(
      grpc::CreateCustomChannel(absl::StrCat("127.0.0.1:", (*server)->port()),
                                grpc::InsecureChannelCredentials(), arguments));

  std::vector<v1::StreamRequest> requests;
  for (v1::Encoding encoding : {v1::FLOAT32, v1::FLOAT16}) {
    for (v1::Compression compression : {v1::COMPRESSION_NONE, v1::ZSTD}) {
      v1::StreamRequest request;
      for (v1::Product product : {v1::RANGE, v1::AMPLITUDE, v1::C0, v1::FLAGS, v1::MOMENT_STATE,
                                  v1::SLICES, v1::CUMULATIVE, v1::DIRECT_INDIRECT}) {
        request.add_products(product);
      }
      request.set_encoding(encoding);
      request.set_compression(compression);
      request.mutable_slices()->set_bins(4);
      requests.push_back(request);
    }
  }
  v1::StreamRequest millimetres;
  millimetres.add_products(v1::RANGE);
  millimetres.add_products(v1::DEPTH);
  millimetres.set_encoding(v1::UINT16_MM);
  requests.push_back(millimetres);
  for (uint32_t bits : {64u, 128u}) {
    v1::StreamRequest moment_depth;
    moment_depth.add_products(v1::MOMENT_DEPTH);
    moment_depth.mutable_moment_depth()->set_bits(bits);
    requests.push_back(moment_depth);
  }
  int written = 0;
  for (size_t i = 0; i < requests.size(); ++i) {
    grpc::ClientContext context;
    context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(30)));
    auto reader = stub->StreamFrames(&context, requests[i]);
    v1::Frame frame;
    while (reader->Read(&frame) && frame.images_size() == 0) {
    }
    context.TryCancel();
    (void)reader->Finish();
    if (frame.images_size() == 0) {
      std::fprintf(stderr, "no frame for request %zu\n", i);
      return 1;
    }
    Write(corpus / "image_codec" / absl::StrCat("frame_", i), frame.SerializeAsString());
    Write(corpus / "rpc" / absl::StrCat("stream_", i),
          std::string(1, '\0') + requests[i].SerializeAsString());
    written += 2;
  }
  v1::GetPixelRequest pixel;
  pixel.set_x(3);
  pixel.set_y(4);
  pixel.set_bins(16);
  pixel.set_bounds_r(0.5);
  Write(corpus / "rpc" / "get_pixel", std::string(1, '\1') + pixel.SerializeAsString());
  v1::Config config;
  config.set_range_method(v1::PISARENKO);
  config.set_threshold(0.2);
  config.set_takes(2);
  config.set_smoothing_sigma_px(0.0);
  Write(corpus / "rpc" / "set_config", std::string(1, '\2') + config.SerializeAsString());
  v1::StartRecordingRequest recording;
  recording.set_path("capture.h5");
  recording.set_max_frames(1);
  Write(corpus / "rpc" / "start_recording", std::string(1, '\3') + recording.SerializeAsString());
  Write(corpus / "rpc" / "get_stats", std::string(1, '\4'));
  written += 4;
  (*pipeline)->Stop();
  (*server)->Shutdown(absl::Seconds(1));
  std::printf("wrote %d seeds into %s\n", written, corpus.c_str());
  return 0;
}

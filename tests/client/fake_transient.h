// A fake transientd, for what the real daemon cannot be made to do: send a corrupt image (it
// encodes every image it sends itself), end a stream cleanly with OK (its streams end only with
// an error status or the client's cancel), offer fewer products, or answer slowly. Shared by
// the client library's tests and the tool's.
#pragma once

#include <grpcpp/grpcpp.h>

#include <bit>
#include <chrono>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "transient/v1/transient.grpc.pb.h"
#include "transient/v1/transient.pb.h"

namespace transient::testing {

inline constexpr int kFakeWidth = 4;
inline constexpr int kFakeHeight = 3;

// Little-endian bytes of the wire, written out byte by byte (the proto says little endian).
inline std::string FloatBytes(const std::vector<float>& values) {
  std::string bytes;
  for (const float value : values) {
    const uint32_t bits = std::bit_cast<uint32_t>(value);
    for (int shift = 0; shift < 32; shift += 8) bytes.push_back(static_cast<char>(bits >> shift));
  }
  return bytes;
}

// Range of pixel i in frame `sequence`: distinct per frame so that "the last frame" is checked.
inline float FakeRange(uint64_t sequence, int i) {
  return i == 5 ? std::numeric_limits<float>::quiet_NaN()
                : 1.0f + 0.01f * static_cast<float>(i) + static_cast<float>(sequence);
}

// A RANGE frame of the fake kFakeWidth x kFakeHeight camera, as the daemon would send it.
inline v1::Frame FakeRangeFrame(uint64_t sequence) {
  v1::Frame frame;
  frame.set_sequence(sequence);
  frame.set_state(v1::STREAMING);
  frame.set_latency_s(0.010);
  std::vector<float> range(kFakeWidth * kFakeHeight);
  for (int i = 0; i < kFakeWidth * kFakeHeight; ++i) range[i] = FakeRange(sequence, i);
  v1::Image* image = frame.add_images();
  image->set_name("range");
  image->set_product(v1::RANGE);
  image->set_width(kFakeWidth);
  image->set_height(kFakeHeight);
  image->set_encoding("32FC1");
  image->set_step(kFakeWidth * 4);
  image->set_unit("m");
  image->set_data(FloatBytes(range));
  return frame;
}

// Sends `frames` range frames, frame number `corrupt_at` with its data truncated, and then ends
// the stream with OK.
class CorruptingTransient final : public v1::Transient::Service {
 public:
  int frames = 3;
  int corrupt_at = 1;

  grpc::Status GetInfo(grpc::ServerContext*, const v1::GetInfoRequest*, v1::Info* info) override {
    info->mutable_camera()->set_width(kFakeWidth);
    info->mutable_camera()->set_height(kFakeHeight);
    info->set_source_uri("sim:fake");
    info->set_version("test");
    info->set_state(v1::STREAMING);
    return grpc::Status::OK;
  }

  grpc::Status StreamFrames(grpc::ServerContext* context, const v1::StreamRequest*,
                            grpc::ServerWriter<v1::Frame>* writer) override {
    for (int i = 0; i < frames && !context->IsCancelled(); ++i) {
      v1::Frame frame = FakeRangeFrame(static_cast<uint64_t>(i));
      if (i == corrupt_at) frame.mutable_images(0)->mutable_data()->resize(7);
      if (!writer->Write(frame)) break;
    }
    return grpc::Status::OK;
  }
};

// A fake service's server on a loopback port chosen at run time.
class FakeDaemon {
 public:
  explicit FakeDaemon(v1::Transient::Service* service) {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service);
    server_ = builder.BuildAndStart();
  }
  ~FakeDaemon() { server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(1)); }
  std::string address() const { return absl::StrCat("127.0.0.1:", port_); }

 private:
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

}  // namespace transient::testing

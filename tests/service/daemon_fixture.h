// A real transientd in the test's process: a Pipeline on a source URI and its gRPC server on a
// loopback port chosen at run time. Shared by the service and the client tests.
#pragma once

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "gtest/gtest.h"
#include "tests/support/wait.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/v1/transient.grpc.pb.h"

namespace transient::service::testing {

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

class Daemon {
 public:
  // start = false: the server answers, but no frame is ever produced until pipeline().Start().
  explicit Daemon(PipelineOptions options, bool start = true) {
    absl::StatusOr<std::unique_ptr<Pipeline>> pipeline = Pipeline::Create(std::move(options));
    EXPECT_TRUE(pipeline.ok()) << pipeline.status();
    if (!pipeline.ok()) return;
    pipeline_ = *std::move(pipeline);
    absl::StatusOr<std::unique_ptr<TransientServer>> server =
        TransientServer::Start(pipeline_.get(), {.listen = "127.0.0.1:0", .version = "test"});
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
  std::string address() const { return absl::StrCat("127.0.0.1:", server_->port()); }
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
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<TransientServer> server_;
};

}  // namespace transient::service::testing

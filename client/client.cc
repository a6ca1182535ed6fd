// Client: the channel to transientd, its unary RPCs with deadlines, Calibrate's progress
// stream, and FrameStreams.
#include "transient/client/client.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include <grpcpp/support/client_interceptor.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "stream_watcher.h"
#include "transient/wire/credentials.h"
#include "transient/wire/grpc_status.h"

namespace transient::client {
namespace {

// How often connecting looks at the cancel flag.
constexpr absl::Duration kConnectPoll = absl::Milliseconds(100);

// Adds the bearer token to the initial metadata of every call of the channel: the unary calls,
// Calibrate and every FrameStream alike.
class TokenInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit TokenInterceptor(const std::string* authorization) : authorization_(authorization) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->insert({wire::kAuthorizationKey, *authorization_});
    }
    methods->Proceed();
  }

 private:
  const std::string* authorization_;
};

class TokenInterceptorFactory final
    : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit TokenInterceptorFactory(std::string token)
      : authorization_(absl::StrCat(wire::kBearerPrefix, token)) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(
      grpc::experimental::ClientRpcInfo*) override {
    return new TokenInterceptor(&authorization_);
  }

 private:
  const std::string authorization_;  // lives with the channel, which owns the factory
};

// The channel's credentials: SSL with the CA (and a client certificate) or plain text.
absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> ChannelCredentials(
    const ChannelSecurity& security) {
  if (security.ca_file.empty()) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;
  absl::StatusOr<std::string> ca =
      wire::ReadPemFile("security.ca_file", security.ca_file, /*secret=*/false);
  if (!ca.ok()) return ca.status();
  ssl.pem_root_certs = *std::move(ca);
  if (!security.cert_file.empty()) {
    absl::StatusOr<std::string> cert =
        wire::ReadPemFile("security.cert_file", security.cert_file, /*secret=*/false);
    if (!cert.ok()) return cert.status();
    absl::StatusOr<std::string> key =
        wire::ReadPemFile("security.key_file", security.key_file, /*secret=*/true);
    if (!key.ok()) return key.status();
    ssl.pem_cert_chain = *std::move(cert);
    ssl.pem_private_key = *std::move(key);
  }
  return grpc::SslCredentials(ssl);
}

bool FiniteAndPositive(double value) { return std::isfinite(value) && value > 0.0; }

}  // namespace

absl::Status ConnectOptions::Validate() const {
  if (address.empty()) {
    return absl::InvalidArgumentError(
        "address = \"\". Violated constraint: a gRPC target, host:port or unix:PATH");
  }
  if (!FiniteAndPositive(timeout_s)) {
    return absl::InvalidArgumentError(
        absl::StrCat("timeout_s = ", timeout_s, ". Violated constraint: finite and > 0"));
  }
  if (!FiniteAndPositive(call_timeout_s)) {
    return absl::InvalidArgumentError(
        absl::StrCat("call_timeout_s = ", call_timeout_s, ". Violated constraint: finite and > 0"));
  }
  if (security.cert_file.empty() != security.key_file.empty()) {
    return absl::InvalidArgumentError(
        "security.cert_file, security.key_file: expected both (a client certificate and its "
        "key) or neither");
  }
  if (security.ca_file.empty() && (!security.cert_file.empty() || !security.server_name.empty())) {
    return absl::InvalidArgumentError(
        "security.ca_file: required with a client certificate or a server name (they are TLS)");
  }
  return absl::OkStatus();
}

Client::Client(std::shared_ptr<grpc::Channel> channel, std::string address,
               double call_timeout_s)
    : channel_(std::move(channel)),
      stub_(v1::Transient::NewStub(channel_)),
      address_(std::move(address)),
      call_timeout_s_(call_timeout_s) {}

absl::StatusOr<Client> Client::Connect(const ConnectOptions& options) {
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(-1);
  if (!options.security.server_name.empty()) {
    arguments.SetSslTargetNameOverride(options.security.server_name);
  }
  absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> credentials =
      ChannelCredentials(options.security);
  if (!credentials.ok()) return credentials.status();
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  if (!options.security.token_file.empty()) {
    absl::StatusOr<std::string> token =
        wire::ReadTokenFile("security.token_file", options.security.token_file);
    if (!token.ok()) return token.status();
    interceptors.push_back(std::make_unique<TokenInterceptorFactory>(*std::move(token)));
  }
  std::shared_ptr<grpc::Channel> channel = grpc::experimental::CreateCustomChannelWithInterceptors(
      options.address, *credentials, arguments, std::move(interceptors));
  const absl::Time deadline = absl::Now() + absl::Seconds(options.timeout_s);
  // In short waits, so that the cancel flag is seen while the daemon does not answer.
  while (!channel->WaitForConnected(
      absl::ToChronoTime(std::min(deadline, absl::Now() + kConnectPoll)))) {
    if (options.cancel != nullptr && options.cancel->load()) {
      return absl::CancelledError(
          absl::StrCat("interrupted while connecting to transientd at ", options.address));
    }
    if (absl::Now() >= deadline) {
      return absl::UnavailableError(absl::StrFormat("cannot reach transientd at %s within %g s",
                                                    options.address, options.timeout_s));
    }
  }
  return Client(std::move(channel), options.address, options.call_timeout_s);
}

std::unique_ptr<grpc::ClientContext> Client::UnaryContext() const {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(call_timeout_s_)));
  return context;
}

absl::Status Client::CallStatus(const char* rpc, const grpc::Status& status) const {
  if (status.ok()) return absl::OkStatus();
  const absl::Status daemon = wire::FromGrpcStatus(status);
  return absl::Status(daemon.code(), absl::StrCat(rpc, " from transientd at ", address_, ": ",
                                                  daemon.message()));
}

absl::StatusOr<v1::Info> Client::GetInfo() const {
  v1::Info info;
  if (absl::Status status =
          CallStatus("GetInfo", stub_->GetInfo(UnaryContext().get(), {}, &info));
      !status.ok()) {
    return status;
  }
  return info;
}

absl::StatusOr<v1::Pixel> Client::GetPixel(const v1::GetPixelRequest& request) const {
  v1::Pixel pixel;
  if (absl::Status status =
          CallStatus("GetPixel", stub_->GetPixel(UnaryContext().get(), request, &pixel));
      !status.ok()) {
    return status;
  }
  return pixel;
}

absl::StatusOr<v1::Config> Client::GetConfig() const {
  v1::Config config;
  if (absl::Status status =
          CallStatus("GetConfig", stub_->GetConfig(UnaryContext().get(), {}, &config));
      !status.ok()) {
    return status;
  }
  return config;
}

absl::StatusOr<v1::Config> Client::SetConfig(const v1::Config& update) const {
  v1::Config config;
  if (absl::Status status =
          CallStatus("SetConfig", stub_->SetConfig(UnaryContext().get(), update, &config));
      !status.ok()) {
    return status;
  }
  return config;
}

absl::StatusOr<v1::Recording> Client::StartRecording(
    const v1::StartRecordingRequest& request) const {
  v1::Recording recording;
  if (absl::Status status = CallStatus(
          "StartRecording", stub_->StartRecording(UnaryContext().get(), request, &recording));
      !status.ok()) {
    return status;
  }
  return recording;
}

absl::StatusOr<v1::Recording> Client::StopRecording() const {
  v1::Recording recording;
  if (absl::Status status = CallStatus(
          "StopRecording", stub_->StopRecording(UnaryContext().get(), {}, &recording));
      !status.ok()) {
    return status;
  }
  return recording;
}

absl::StatusOr<v1::Stats> Client::GetStats() const {
  v1::Stats stats;
  if (absl::Status status =
          CallStatus("GetStats", stub_->GetStats(UnaryContext().get(), {}, &stats));
      !status.ok()) {
    return status;
  }
  return stats;
}

absl::StatusOr<v1::CalibrateResult> Client::Calibrate(const v1::CalibrateRequest& request,
                                                      const CalibrateProgressFn& on_progress,
                                                      const std::atomic<bool>* cancel) const {
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<v1::CalibrateProgress>> reader =
      stub_->Calibrate(&context, request);
  std::optional<v1::CalibrateResult> result;
  grpc::Status status;
  bool interrupted = false;
  {
    std::optional<StreamWatcher> watcher;
    if (cancel != nullptr) watcher.emplace(&context, cancel, absl::InfiniteFuture());
    v1::CalibrateProgress progress;
    while (reader->Read(&progress)) {
      if (progress.has_result()) result = progress.result();
      if (on_progress) {
        on_progress(static_cast<int>(progress.done()), static_cast<int>(progress.total()));
      }
    }
    status = reader->Finish();
    interrupted = watcher && watcher->reason() == StreamWatcher::Reason::kInterrupted;
  }
  if (interrupted && status.error_code() == grpc::StatusCode::CANCELLED) {
    return absl::CancelledError(
        absl::StrCat("Calibrate at transientd at ", address_, " interrupted"));
  }
  if (absl::Status failed = CallStatus("Calibrate", status); !failed.ok()) return failed;
  if (!result) {
    return absl::DataLossError(absl::StrCat(
        "Calibrate from transientd at ", address_,
        ": the stream ended without a result. Violated constraint: the last message has one"));
  }
  return *result;
}

std::unique_ptr<FrameStream> Client::StreamFrames(const v1::StreamRequest& request,
                                                  const StreamOptions& options) const {
  return std::unique_ptr<FrameStream>(new FrameStream(channel_, address_, request, options));
}

}  // namespace transient::client

// A connection to transientd and its RPCs (proto/transient/v1/transient.proto) as blocking
// calls with absl::Status results: the daemon's status code and message come back as they were
// sent (wire::FromGrpcStatus), prefixed with the call and the address.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/client/frame_stream.h"
#include "transient/v1/transient.grpc.pb.h"
#include "transient/v1/transient.pb.h"

namespace transient::client {

// How to reach a daemon that requires TLS or authentication (transientd --tls-cert,
// --client-ca, --token-file; docs/security.md). Files, never the secrets themselves.
struct ChannelSecurity {
  std::string ca_file = {};      // PEM CA of the daemon's certificate: TLS; "" = plain text
  std::string cert_file = {};    // PEM client certificate (mutual TLS); with key_file and ca_file
  std::string key_file = {};     // its private key
  std::string server_name = {};  // the name the daemon's certificate must carry; "" = the host
  std::string token_file = {};   // sent with every call as `authorization: Bearer <token>`
};

struct ConnectOptions {
  std::string address;  // gRPC target of transientd: host:port, or unix:PATH
  ChannelSecurity security = {};
  double timeout_s = 5.0;       // to wait for the connection, > 0
  double call_timeout_s = 10.0;  // deadline of each unary call (not of streams), > 0
  // Connecting gives up with Cancelled when *cancel turns true. May be null.
  const std::atomic<bool>* cancel = nullptr;

  // InvalidArgument naming the field, the value and the rule: a non-empty address, finite
  // timeouts > 0, a client certificate with its key and a CA, a server name with a CA.
  absl::Status Validate() const;
};

// Progress of Client::Calibrate: takes done of total.
using CalibrateProgressFn = std::function<void(int done, int total)>;

// Thread-safe: calls may run from several threads at once, and streams outlive the Client.
class Client {
 public:
  // Opens a channel (no limit on the size of a received message: a frame of many full-sensor
  // slices is large; TLS and the token as options.security says, the files read here with
  // InvalidArgument naming the field when one cannot be used) and waits until it is connected
  // (a TLS handshake the daemon refuses never connects). Unavailable "cannot reach transientd at
  // ADDR within T s" when it is not within options.timeout_s; Cancelled "interrupted while
  // connecting to transientd at ADDR" when *options.cancel turns true first.
  [[nodiscard]] static absl::StatusOr<Client> Connect(const ConnectOptions& options);

  const std::string& address() const { return address_; }

  // The unary RPCs, each with the deadline options.call_timeout_s. A failure keeps the
  // daemon's code (DeadlineExceeded for the deadline) and is prefixed "<Rpc> from transientd at
  // ADDR: ".
  [[nodiscard]] absl::StatusOr<v1::Info> GetInfo() const;
  [[nodiscard]] absl::StatusOr<v1::Pixel> GetPixel(const v1::GetPixelRequest& request) const;
  [[nodiscard]] absl::StatusOr<v1::Config> GetConfig() const;
  // Changes the fields that are set; returns the configuration now in use.
  [[nodiscard]] absl::StatusOr<v1::Config> SetConfig(const v1::Config& update) const;
  [[nodiscard]] absl::StatusOr<v1::Recording> StartRecording(
      const v1::StartRecordingRequest& request) const;
  [[nodiscard]] absl::StatusOr<v1::Recording> StopRecording() const;
  [[nodiscard]] absl::StatusOr<v1::Stats> GetStats() const;

  // Calibrates (a stream without deadline: it takes as long as its takes), calling
  // on_progress(done, total) for each take, and returns the result. Cancelled when *cancel
  // turns true; DataLoss when the stream ends without a result; otherwise prefixed as above.
  [[nodiscard]] absl::StatusOr<v1::CalibrateResult> Calibrate(
      const v1::CalibrateRequest& request, const CalibrateProgressFn& on_progress = {},
      const std::atomic<bool>* cancel = nullptr) const;

  // Subscribes to frames. Nothing is checked here: a request the daemon refuses ends the
  // stream at once and FrameStream::Finish returns the daemon's InvalidArgument.
  [[nodiscard]] std::unique_ptr<FrameStream> StreamFrames(const v1::StreamRequest& request,
                                                          const StreamOptions& options = {}) const;

 private:
  Client(std::shared_ptr<grpc::Channel> channel, std::string address, double call_timeout_s);

  // A context with the unary deadline.
  std::unique_ptr<grpc::ClientContext> UnaryContext() const;
  // OK, or `status` (from the daemon) prefixed with the call and the address.
  absl::Status CallStatus(const char* rpc, const grpc::Status& status) const;

  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::Transient::Stub> stub_;
  std::string address_;
  double call_timeout_s_ = 10.0;
};

}  // namespace transient::client

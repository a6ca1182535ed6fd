// The gRPC server of transientd: the `transient.v1.Transient` service over a Pipeline, with
// standard health checking and server reflection (DESIGN.md, "Wire protocol").
#pragma once

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "transient/service/access.h"
#include "transient/service/pipeline.h"
#include "transient/wire/address.h"

namespace grpc {
class Server;
}

namespace transient::service {

class NatsPublisher;

struct ServerOptions {
  std::string listen = wire::kDefaultAddress;  // host:port; port 0 = one chosen by the system
  std::string version = "";
  // Credentials and the check of every transient.v1 call (health checking answers without;
  // reflection is off when calls need a token or a client certificate); nullptr = plain text,
  // every call accepted (Access::Load decides whether that may serve `listen`).
  std::shared_ptr<const Access> access = nullptr;
  // The NATS publisher whose counters GetStats reports (Stats.nats); null = none. Not owned;
  // it must outlive the server.
  const NatsPublisher* nats = nullptr;
};

class TransientServer {
 public:
  // Binds and starts serving `pipeline` (not owned; it must outlive the server).
  // Unavailable naming the address when it cannot be bound.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<TransientServer>> Start(
      Pipeline* pipeline, const ServerOptions& options);
  ~TransientServer();

  int port() const { return port_; }
  std::string address() const;  // host:port actually bound
  // Ends every stream (the pipeline must be stopped first, which closes the subscriptions) and
  // cancels RPCs still running after `deadline`.
  void Shutdown(absl::Duration deadline);

 private:
  TransientServer() = default;
  class Service;
  std::unique_ptr<Service> service_;
  std::unique_ptr<grpc::Server> server_;
  std::string host_;
  int port_ = 0;
};

}  // namespace transient::service

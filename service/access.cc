// transientd's access rules, its gRPC server credentials and the check of every call.
#include "transient/service/access.h"

#include <grpcpp/security/auth_context.h>

#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "transient/wire/address.h"
#include "transient/wire/credentials.h"

namespace transient::service {

absl::StatusOr<Access> Access::Load(const AccessOptions& options, const std::string& listen) {
  Access access;
  access.insecure_ = options.insecure;
  access.loopback_ = wire::IsLoopback(listen);
  if (options.tls_cert_file.empty() != options.tls_key_file.empty()) {
    return absl::InvalidArgumentError(
        "--tls-cert and --tls-key: expected both (the daemon's certificate and its key) or "
        "neither");
  }
  if (!options.client_ca_file.empty() && options.tls_cert_file.empty()) {
    return absl::InvalidArgumentError(
        "--client-ca: client certificates need TLS (--tls-cert and --tls-key)");
  }
  if (!options.tls_cert_file.empty()) {
    absl::StatusOr<std::string> cert =
        wire::ReadPemFile("--tls-cert", options.tls_cert_file, /*secret=*/false);
    if (!cert.ok()) return cert.status();
    absl::StatusOr<std::string> key =
        wire::ReadPemFile("--tls-key", options.tls_key_file, /*secret=*/true);
    if (!key.ok()) return key.status();
    access.cert_pem_ = *std::move(cert);
    access.key_pem_ = *std::move(key);
  }
  if (!options.client_ca_file.empty()) {
    absl::StatusOr<std::string> ca =
        wire::ReadPemFile("--client-ca", options.client_ca_file, /*secret=*/false);
    if (!ca.ok()) return ca.status();
    access.client_ca_pem_ = *std::move(ca);
  }
  if (!options.token_file.empty()) {
    absl::StatusOr<std::string> token = wire::ReadTokenFile("--token-file", options.token_file);
    if (!token.ok()) return token.status();
    access.token_ = *std::move(token);
  }
  if (!access.loopback_ && !options.insecure &&
      (!access.tls() || (!access.token_required() && !access.client_certificate_required()))) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--listen ", listen, " serves other machines, ",
        access.tls() ? "with TLS but without authentication" : "without TLS or authentication",
        ": give --tls-cert and --tls-key with --token-file and/or --client-ca, or --insecure "
        "to serve anyone who reaches the port (they could record, calibrate and reconfigure)"));
  }
  return access;
}

std::shared_ptr<grpc::ServerCredentials> Access::ServerCredentials() const {
  if (!tls()) return grpc::InsecureServerCredentials();
  // A client certificate is asked for and verified when given; Authorize requires it for the
  // transient.v1 calls, so that the health service stays reachable for probes without one.
  grpc::SslServerCredentialsOptions ssl(client_certificate_required()
                                            ? GRPC_SSL_REQUEST_CLIENT_CERTIFICATE_AND_VERIFY
                                            : GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  ssl.pem_root_certs = client_ca_pem_;
  ssl.pem_key_cert_pairs.push_back({key_pem_, cert_pem_});
  return grpc::SslServerCredentials(ssl);
}

grpc::Status Access::Authorize(const grpc::ServerContext& context) const {
  if (client_certificate_required()) {
    const std::shared_ptr<const grpc::AuthContext> auth = context.auth_context();
    if (auth == nullptr || !auth->IsPeerAuthenticated()) {
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                          "transientd requires a client certificate signed by its client CA");
    }
  }
  if (token_required()) {
    const auto& metadata = context.client_metadata();
    const auto found = metadata.find(wire::kAuthorizationKey);
    if (found == metadata.end()) {
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                          "transientd requires a bearer token (authorization: Bearer ...)");
    }
    const absl::string_view value(found->second.data(), found->second.size());
    const absl::string_view prefix = wire::kBearerPrefix;
    const bool bearer = absl::StartsWith(value, prefix);
    if (!wire::TokensEqual(bearer ? value.substr(prefix.size()) : absl::string_view(), token_)) {
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "transientd refuses the bearer token");
    }
  }
  return grpc::Status::OK;
}

std::string Access::Describe() const {
  std::string line = tls() ? "TLS" : "plain text";
  if (client_certificate_required()) absl::StrAppend(&line, ", client certificates");
  if (token_required()) absl::StrAppend(&line, ", bearer token");
  if (loopback_) {
    absl::StrAppend(&line, " (loopback)");
  } else if (insecure_ && (!tls() || (!token_required() && !client_certificate_required()))) {
    absl::StrAppend(&line, "; INSECURE (--insecure): anyone who reaches the port may call it");
  }
  return line;
}

}  // namespace transient::service

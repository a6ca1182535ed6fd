// Who may call transientd (docs/security.md): the transport (plain text on loopback, TLS with
// the daemon's certificate and key), client certificates signed by a CA the daemon is given
// (mutual TLS), and a bearer token every call must carry. Serving any other address than
// loopback without TLS and one of the two is refused, unless the user says --insecure.
#pragma once

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_context.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"

namespace transient::service {

struct AccessOptions {
  std::string tls_cert_file = {};   // PEM certificate (chain) of the daemon; with tls_key_file
  std::string tls_key_file = {};    // PEM private key (not readable by others)
  std::string client_ca_file = {};  // PEM CA: every call needs a client certificate it signed
  std::string token_file = {};      // every call needs `authorization: Bearer <the file's token>`
  bool insecure = false;            // serve a non-loopback address without TLS and authentication
};

class Access {
 public:
  // Reads the files (wire::ReadPemFile, wire::ReadTokenFile) and checks the rules for
  // `listen`; InvalidArgument naming the option otherwise: a certificate without its key or
  // the reverse; a client CA without TLS; a non-loopback address without TLS and a token or
  // client CA, unless options.insecure (the message says what is missing and the risk).
  [[nodiscard]] static absl::StatusOr<Access> Load(const AccessOptions& options,
                                                   const std::string& listen);

  // The server's credentials: SSL with the certificate and key (asking clients for a
  // certificate, and verifying one if given, with a client CA), else plain text.
  std::shared_ptr<grpc::ServerCredentials> ServerCredentials() const;

  // OK when the call may go on: with a client CA, the peer presented a certificate the
  // handshake verified; with a token, the call carries it (wire::TokensEqual). UNAUTHENTICATED
  // saying what is missing or wrong, never what the token is.
  grpc::Status Authorize(const grpc::ServerContext& context) const;

  bool tls() const { return !cert_pem_.empty(); }
  bool client_certificate_required() const { return !client_ca_pem_.empty(); }
  bool token_required() const { return !token_.empty(); }
  bool insecure() const { return insecure_; }
  // One line for the log: "TLS, client certificates, bearer token", "plain text (loopback)",
  // "plain text, INSECURE: ...".
  std::string Describe() const;

 private:
  Access() = default;

  std::string cert_pem_, key_pem_, client_ca_pem_, token_;
  bool insecure_ = false;  // --insecure was given
  bool loopback_ = true;
};

}  // namespace transient::service

// Who may call transientd: the rules at start, and real gRPC over loopback with TLS (OpenSSL's
// command line makes two CAs and their certificates for the test), client certificates and a
// bearer token, through the client library and raw stubs.
#include "transient/service/access.h"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <signal.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/certificates.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "transient/client/client.h"
#include "transient/wire/address.h"
#include "transient/wire/credentials.h"

namespace transient::service {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::kSmallSim;
using ::transient::service::testing::Request;
using ::transient::testing::Certificates;
using ::transient::testing::IsOk;
using ::transient::testing::RunProcess;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

constexpr char kToken[] = "0123456789abcdef0123456789abcdef";

void WriteFile(const std::string& path, const std::string& content, mode_t mode = 0600) {
  std::ofstream(path) << content;
  ::chmod(path.c_str(), mode);
}

TEST(Access, LoopbackIsThisMachineOnly) {
  for (const char* address : {"127.0.0.1:50051", "127.1.2.3:0", "localhost:1", "[::1]:5",
                              "unix:/tmp/transientd.sock", "unix-abstract:transientd"}) {
    EXPECT_TRUE(wire::IsLoopback(address)) << address;
  }
  for (const char* address : {"0.0.0.0:50051", "[::]:1", "192.168.1.2:1", "camera-pc:1",
                              "127.0.0.1.example.com:1", "128.0.0.1:1", "127.0.0.256:1"}) {
    EXPECT_FALSE(wire::IsLoopback(address)) << address;
  }
}

TEST(Access, TokensCompareWholly) {
  EXPECT_TRUE(wire::TokensEqual(kToken, kToken));
  const std::string token = kToken;
  for (size_t i = 0; i < token.size(); ++i) {
    std::string wrong = token;
    wrong[i] ^= 1;
    EXPECT_FALSE(wire::TokensEqual(wrong, token)) << i;
  }
  EXPECT_FALSE(wire::TokensEqual(token.substr(0, 31), token));
  EXPECT_FALSE(wire::TokensEqual(token + "0", token));
  EXPECT_FALSE(wire::TokensEqual("", token));
  EXPECT_FALSE(wire::TokensEqual(std::string(token.size(), '\0'), token));
}

TEST(Access, TheRulesAtStartNameWhatIsMissing) {
  ScratchDirectory dir;
  WriteFile(dir.File("token"), absl::StrCat(kToken, "\n"));
  WriteFile(dir.File("short"), "abc\n");
  WriteFile(dir.File("spaced"), "0123456789 abcdef0123\n");
  WriteFile(dir.File("shared"), kToken, 0644);
  WriteFile(dir.File("cert.pem"), "-----BEGIN CERTIFICATE-----\nx\n-----END CERTIFICATE-----\n",
            0644);
  WriteFile(dir.File("key.pem"), "-----BEGIN PRIVATE KEY-----\nx\n-----END PRIVATE KEY-----\n");
  WriteFile(dir.File("shared-key.pem"), "-----BEGIN PRIVATE KEY-----\n", 0644);
  WriteFile(dir.File("text.pem"), "not a certificate\n", 0644);

  struct Case {
    AccessOptions options;
    std::string listen;
    std::string message;
  };
  const std::vector<Case> refused = {
      {{}, "0.0.0.0:0", "serves other machines, without TLS or authentication"},
      {{.token_file = dir.File("token")}, "0.0.0.0:0", "without TLS or authentication"},
      {{.tls_cert_file = dir.File("cert.pem"), .tls_key_file = dir.File("key.pem")},
       "[::]:1",
       "with TLS but without authentication"},
      {{.tls_cert_file = dir.File("cert.pem")}, "127.0.0.1:0", "expected both"},
      {{.client_ca_file = dir.File("cert.pem")}, "127.0.0.1:0", "need TLS"},
      {{.token_file = dir.File("short")}, "127.0.0.1:0", "a token of 3 bytes; expected 16"},
      {{.token_file = dir.File("spaced")}, "127.0.0.1:0", "a space, control"},
      {{.token_file = dir.File("shared")}, "127.0.0.1:0", "readable by every user"},
      {{.token_file = dir.File("missing")}, "127.0.0.1:0", "missing: cannot be read"},
      {{.tls_cert_file = dir.File("cert.pem"), .tls_key_file = dir.File("shared-key.pem")},
       "127.0.0.1:0",
       "--tls-key"},
      {{.tls_cert_file = dir.File("text.pem"), .tls_key_file = dir.File("key.pem")},
       "127.0.0.1:0",
       "not PEM"},
  };
  for (const Case& c : refused) {
    EXPECT_THAT(Access::Load(c.options, c.listen).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)))
        << c.listen << " " << c.message;
  }
  const absl::StatusOr<Access> insecure = Access::Load({.insecure = true}, "0.0.0.0:0");
  ASSERT_THAT(insecure.status(), IsOk());
  EXPECT_THAT(insecure->Describe(), HasSubstr("INSECURE"));
  const absl::StatusOr<Access> token =
      Access::Load({.token_file = dir.File("token")}, "127.0.0.1:0");
  ASSERT_THAT(token.status(), IsOk());
  EXPECT_TRUE(token->token_required());
  EXPECT_EQ(token->Describe(), "plain text, bearer token (loopback)");
}

std::shared_ptr<const Access> MustLoad(const AccessOptions& options) {
  absl::StatusOr<Access> access = Access::Load(options, "127.0.0.1:0");
  EXPECT_THAT(access.status(), IsOk());
  return access.ok() ? std::make_shared<const Access>(*std::move(access)) : nullptr;
}

// A connection that is refused is waited for 1 s: the handshake fails at once on loopback.
absl::StatusOr<client::Client> ConnectWith(const Daemon& daemon,
                                           const client::ChannelSecurity& security,
                                           double timeout_s = 5.0) {
  return client::Client::Connect(
      {.address = daemon.address(), .security = security, .timeout_s = timeout_s});
}

// The first frame of a RANGE stream through the client library, or how the stream ended.
absl::Status StreamOneFrame(const client::Client& client) {
  std::unique_ptr<client::FrameStream> stream = client.StreamFrames(Request({v1::RANGE}));
  client::StreamFrame frame;
  while (stream->Next(&frame)) {
    if (frame.kind == client::StreamFrame::Kind::kImages) return absl::OkStatus();
  }
  absl::Status status = stream->Finish();
  return status.ok() ? absl::DataLossError("the stream ended without a frame") : status;
}

grpc::Status RawGetInfo(const Daemon& daemon, const std::string& authorization) {
  grpc::ClientContext context;
  if (!authorization.empty()) context.AddMetadata(wire::kAuthorizationKey, authorization);
  v1::Info info;
  return testing::Connect(daemon.port())->GetInfo(&context, {}, &info);
}

// grpc.health.v1.Health/Check of the whole server over plain text, as a probe without
// credentials sends it: the response's bytes, or the status.
std::string HealthCheck(const Daemon& daemon) {
  grpc::GenericStub generic(
      grpc::CreateChannel(daemon.address(), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(10)));
  grpc::Slice empty("");
  const grpc::ByteBuffer request(&empty, 1);  // HealthCheckRequest{service: ""}
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  generic.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request,
                    &response, [&done](grpc::Status status) { done.set_value(status); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok())
    return absl::StrCat("status ", status.error_code(), ": ", status.error_message());
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return "an unreadable response";
  std::string bytes;
  for (const grpc::Slice& slice : slices) {
    bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return bytes;
}

TEST(Access, ATokenIsRequiredOfEveryCallOnLoopback) {
  ScratchDirectory dir;
  WriteFile(dir.File("token"), kToken);
  WriteFile(dir.File("wrong"), "0123456789abcdef0123456789abcdeF");
  Daemon daemon(PipelineOptions{.source_uri = kSmallSim}, /*start=*/true,
                MustLoad({.token_file = dir.File("token")}));

  // Without a token, with a wrong one, with the right one not as a bearer token.
  for (const std::string& authorization :
       {std::string(), absl::StrCat("Bearer ", kToken, "0"), std::string("Bearer 0123"),
        std::string(kToken), absl::StrCat("bearer ", kToken)}) {
    const grpc::Status status = RawGetInfo(daemon, authorization);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << authorization;
    EXPECT_THAT(status.error_message(), Not(HasSubstr(kToken)));
  }
  EXPECT_TRUE(RawGetInfo(daemon, absl::StrCat("Bearer ", kToken)).ok());

  // Every RPC of the client library is refused without the token, with its code.
  absl::StatusOr<client::Client> anonymous = ConnectWith(daemon, {});
  ASSERT_THAT(anonymous.status(), IsOk());
  EXPECT_THAT(anonymous->GetInfo().status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("requires a bearer token")));
  EXPECT_THAT(anonymous->GetStats().status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  EXPECT_THAT(anonymous->GetConfig().status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  EXPECT_THAT(anonymous->SetConfig({}).status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  EXPECT_THAT(anonymous->GetPixel({}).status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  EXPECT_THAT(anonymous->StartRecording({}).status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  EXPECT_THAT(anonymous->StopRecording().status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  EXPECT_THAT(anonymous->Calibrate({}).status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  EXPECT_THAT(StreamOneFrame(*anonymous),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));
  absl::StatusOr<client::Client> wrong = ConnectWith(daemon, {.token_file = dir.File("wrong")});
  ASSERT_THAT(wrong.status(), IsOk());
  EXPECT_THAT(wrong->GetInfo().status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("refuses the bearer token")));

  // The health service answers probes without a token, and says only SERVING.
  EXPECT_EQ(HealthCheck(daemon), "\x08\x01");  // HealthCheckResponse{status: SERVING}

  absl::StatusOr<client::Client> good = ConnectWith(daemon, {.token_file = dir.File("token")});
  ASSERT_THAT(good.status(), IsOk());
  absl::StatusOr<v1::Info> info = good->GetInfo();
  ASSERT_THAT(info.status(), IsOk());
  EXPECT_TRUE(info->access().token());
  EXPECT_FALSE(info->access().tls());
  EXPECT_THAT(StreamOneFrame(*good), IsOk());
}

TEST(Access, TlsWithClientCertificatesAndATokenAdmitsOnlyTheRightClient) {
  Certificates certs;
  ASSERT_TRUE(certs.ok());
  ScratchDirectory dir;
  WriteFile(dir.File("token"), kToken);
  Daemon daemon(PipelineOptions{.source_uri = kSmallSim}, /*start=*/true,
                MustLoad({.tls_cert_file = certs.File("server", "pem"),
                          .tls_key_file = certs.File("server", "key"),
                          .client_ca_file = certs.File("ca", "pem"),
                          .token_file = dir.File("token")}));
  const client::ChannelSecurity good{.ca_file = certs.File("ca", "pem"),
                                     .cert_file = certs.File("client", "pem"),
                                     .key_file = certs.File("client", "key"),
                                     .token_file = dir.File("token")};

  absl::StatusOr<client::Client> client = ConnectWith(daemon, good);
  ASSERT_THAT(client.status(), IsOk());
  absl::StatusOr<v1::Info> info = client->GetInfo();
  ASSERT_THAT(info.status(), IsOk());
  EXPECT_TRUE(info->access().tls());
  EXPECT_TRUE(info->access().client_certificate());
  EXPECT_TRUE(info->access().token());
  EXPECT_THAT(StreamOneFrame(*client), IsOk());

  // The token without a client certificate: the handshake passes (the certificate is asked
  // for, not required, so that probes reach the health service), the call does not.
  client::ChannelSecurity no_certificate = good;
  no_certificate.cert_file.clear();
  no_certificate.key_file.clear();
  absl::StatusOr<client::Client> uncertified = ConnectWith(daemon, no_certificate);
  ASSERT_THAT(uncertified.status(), IsOk());
  EXPECT_THAT(uncertified->GetInfo().status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("client certificate")));

  // A certificate and token but no token: refused.
  client::ChannelSecurity no_token = good;
  no_token.token_file.clear();
  absl::StatusOr<client::Client> tokenless = ConnectWith(daemon, no_token);
  ASSERT_THAT(tokenless.status(), IsOk());
  EXPECT_THAT(tokenless->GetInfo().status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("transientd requires")));

  // A client certificate from another CA fails the handshake: no connection at all.
  client::ChannelSecurity stranger = good;
  stranger.cert_file = certs.File("stranger", "pem");
  stranger.key_file = certs.File("stranger", "key");
  EXPECT_THAT(ConnectWith(daemon, stranger, 1.0).status(),
              StatusIs(absl::StatusCode::kUnavailable, HasSubstr("cannot reach")));
  // A client that trusts another CA refuses the daemon's certificate.
  client::ChannelSecurity distrust = good;
  distrust.ca_file = certs.File("other-ca", "pem");
  EXPECT_THAT(ConnectWith(daemon, distrust, 1.0).status(),
              StatusIs(absl::StatusCode::kUnavailable, HasSubstr("cannot reach")));
  // Plain text to a TLS port does not connect either.
  EXPECT_THAT(ConnectWith(daemon, {.token_file = dir.File("token")}, 1.0).status(),
              StatusIs(absl::StatusCode::kUnavailable, HasSubstr("cannot reach")));
}

#ifdef TRANSIENTD_BINARY

// transientd itself: a non-loopback address without credentials exits 2 naming the problem;
// with --insecure it serves and says so; with TLS and a token it serves authenticated clients.
TEST(AccessBinary, ANonLoopbackAddressNeedsCredentialsOrInsecure) {
  const std::vector<std::string> base = {TRANSIENTD_BINARY, "--source", kSmallSim,
                                         "--uncalibrated",  "--listen", "0.0.0.0:0"};
  const transient::testing::ProcessResult refused = RunProcess(base);
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_THAT(refused.err, HasSubstr("--listen 0.0.0.0:0 serves other machines, without TLS"));

  Certificates certs;
  ASSERT_TRUE(certs.ok());
  ScratchDirectory dir;
  WriteFile(dir.File("token"), kToken);
  struct Case {
    std::vector<std::string> args;
    client::ChannelSecurity security;
    std::string logged;
  };
  const std::vector<Case> cases = {
      {{"--insecure"}, {}, "INSECURE (--insecure)"},
      {{"--tls-cert", certs.File("server", "pem"), "--tls-key", certs.File("server", "key"),
        "--token-file", dir.File("token")},
       {.ca_file = certs.File("ca", "pem"), .token_file = dir.File("token")},
       "access: TLS, bearer token"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const Case& c = cases[i];
    const std::string log_path = dir.File(absl::StrCat("transientd", i, ".log"));
    std::vector<std::string> argv = base;
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const std::string port_file = dir.File("port");
    std::filesystem::remove(port_file);
    argv.insert(argv.end(), {"--port-file", port_file, "--data-dir", dir.File("data")});
    transient::testing::ChildProcess daemon(argv, log_path);
    ASSERT_TRUE(daemon.started());
    const int port = transient::testing::WaitForPortFile(port_file);
    ASSERT_GT(port, 0) << "transientd did not serve: " << c.logged;
    absl::StatusOr<client::Client> client = client::Client::Connect(
        {.address = absl::StrCat("127.0.0.1:", port), .security = c.security});
    ASSERT_THAT(client.status(), IsOk());
    absl::StatusOr<v1::Info> info = client->GetInfo();
    ASSERT_THAT(info.status(), IsOk());
    EXPECT_EQ(info->access().insecure(), c.args.front() == "--insecure");
    EXPECT_EQ(info->access().tls(), !c.security.ca_file.empty());
    ASSERT_TRUE(daemon.Signal(SIGTERM));
    EXPECT_EQ(daemon.Wait(), 0);
    std::ifstream log(log_path);
    EXPECT_THAT(std::string(std::istreambuf_iterator<char>(log), {}), HasSubstr(c.logged));
  }
}
#endif

}  // namespace
}  // namespace transient::service

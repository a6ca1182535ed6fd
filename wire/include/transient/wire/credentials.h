// The secrets both sides of the protocol read from files (never from command lines, which every
// user of the machine can see in /proc): PEM certificates and keys for TLS, and the bearer
// token sent as `authorization: Bearer <token>` with every call (docs/security.md).
#pragma once

#include <string>
#include <utility>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace transient::wire {

// The metadata key and value prefix of the bearer token (RFC 6750, gRPC's convention).
inline constexpr char kAuthorizationKey[] = "authorization";
inline constexpr char kBearerPrefix[] = "Bearer ";
// A shorter token can be guessed; 32 random bytes in hex (`openssl rand -hex 32`) are 64.
inline constexpr size_t kMinTokenBytes = 16;
inline constexpr size_t kMaxTokenBytes = 4096;

// The token in `path`: its content without a trailing newline. InvalidArgument naming the
// option `what` and the path when it cannot be read, when others may read it (mode & 0004:
// `chmod 600`), or when the token is shorter than kMinTokenBytes, longer than kMaxTokenBytes,
// or holds anything but printable ASCII without spaces (it travels in a header).
[[nodiscard]] absl::StatusOr<std::string> ReadTokenFile(absl::string_view what,
                                                        const std::string& path);

// A PEM file's content (certificates, or a private key when `secret`, which others must not be
// able to read either). InvalidArgument naming `what` and the path when it cannot be read, is
// empty or holds no "-----BEGIN " block.
[[nodiscard]] absl::StatusOr<std::string> ReadPemFile(absl::string_view what,
                                                      const std::string& path, bool secret);

// The user name and password in `path`: "user:password" on one line (a NATS server's
// `authorization { user, password }`). InvalidArgument naming `what` and the path when it cannot
// be read, others may read it, or it holds no ':' or an empty user.
[[nodiscard]] absl::StatusOr<std::pair<std::string, std::string>> ReadUserPasswordFile(
    absl::string_view what, const std::string& path);

// OK when `path` is a regular file that other users cannot read (a secret a library
// reads itself, e.g. a NATS .creds file); InvalidArgument naming `what` and the path otherwise.
[[nodiscard]] absl::Status CheckSecretFile(absl::string_view what, const std::string& path);

// Whether `given` equals `expected`, in a time that depends only on expected.size(): a wrong
// token takes as long to refuse as any other of the same length, whatever prefix it shares.
bool TokensEqual(absl::string_view given, absl::string_view expected);

}  // namespace transient::wire

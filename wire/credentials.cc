// Secrets from files, and the constant-time comparison of tokens.
#include "transient/wire/credentials.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace transient::wire {
namespace {

absl::StatusOr<std::string> ReadSecretFile(absl::string_view what, const std::string& path,
                                           bool secret) {
  if (path.empty()) return absl::InvalidArgumentError(absl::StrCat(what, ": expected a file"));
  struct stat info;
  if (::stat(path.c_str(), &info) != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " ", path, ": cannot be read (", std::strerror(errno), ")"));
  }
  if (!S_ISREG(info.st_mode)) {
    return absl::InvalidArgumentError(absl::StrCat(what, " ", path, ": not a regular file"));
  }
  if (secret && (info.st_mode & S_IROTH) != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, " ", path, ": readable by every user of the machine (chmod 600 ", path, ")"));
  }
  if (info.st_size > 1 << 20) {
    return absl::InvalidArgumentError(absl::StrCat(what, " ", path, ": larger than 1 MiB"));
  }
  std::ifstream file(path, std::ios::binary);
  std::ostringstream content;
  content << file.rdbuf();
  if (!file.good() && !file.eof()) {
    return absl::InvalidArgumentError(absl::StrCat(what, " ", path, ": cannot be read"));
  }
  return content.str();
}

}  // namespace

absl::StatusOr<std::string> ReadTokenFile(absl::string_view what, const std::string& path) {
  absl::StatusOr<std::string> token = ReadSecretFile(what, path, /*secret=*/true);
  if (!token.ok()) return token.status();
  while (!token->empty() && (token->back() == '\n' || token->back() == '\r')) token->pop_back();
  if (token->size() < kMinTokenBytes || token->size() > kMaxTokenBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " ", path, ": a token of ", token->size(), " bytes; expected ",
                     kMinTokenBytes, "..", kMaxTokenBytes, " (e.g. `openssl rand -hex 32`)"));
  }
  for (char c : *token) {
    if (c <= ' ' || c > '~') {
      return absl::InvalidArgumentError(absl::StrCat(
          what, " ", path, ": the token holds a space, control or non-ASCII character"));
    }
  }
  return token;
}

absl::StatusOr<std::string> ReadPemFile(absl::string_view what, const std::string& path,
                                        bool secret) {
  absl::StatusOr<std::string> pem = ReadSecretFile(what, path, secret);
  if (!pem.ok()) return pem.status();
  if (pem->find("-----BEGIN ") == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " ", path, ": not PEM (no \"-----BEGIN \" line)"));
  }
  return pem;
}

absl::StatusOr<std::pair<std::string, std::string>> ReadUserPasswordFile(absl::string_view what,
                                                                         const std::string& path) {
  absl::StatusOr<std::string> line = ReadSecretFile(what, path, /*secret=*/true);
  if (!line.ok()) return line.status();
  while (!line->empty() && (line->back() == '\n' || line->back() == '\r')) line->pop_back();
  const size_t colon = line->find(':');
  if (colon == std::string::npos || colon == 0 || line->find('\n') != std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " ", path, ": expected one line \"user:password\""));
  }
  return std::make_pair(line->substr(0, colon), line->substr(colon + 1));
}

absl::Status CheckSecretFile(absl::string_view what, const std::string& path) {
  return ReadSecretFile(what, path, /*secret=*/true).status();
}

bool TokensEqual(absl::string_view given, absl::string_view expected) {
  // Every byte of `expected` is looked at, against `given` or against 0 beyond its end; the
  // differences are OR-ed, never branched on. The length of `given` only picks the operand.
  volatile unsigned char difference = given.size() == expected.size() ? 0 : 1;
  for (size_t i = 0; i < expected.size(); ++i) {
    const unsigned char other = i < given.size() ? static_cast<unsigned char>(given[i]) : 0;
    difference = difference | (static_cast<unsigned char>(expected[i]) ^ other);
  }
  return difference == 0;
}

}  // namespace transient::wire

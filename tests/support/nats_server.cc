// NatsServer: nats-server as a child process (nats_server.h).
#include "tests/support/nats_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "gtest/gtest.h"
#include "tests/support/network.h"
#include "tests/support/wait.h"

namespace transient::testing {
namespace {

bool Accepts(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(static_cast<uint16_t>(port));
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
  ::close(fd);
  return ok;
}

}  // namespace

NatsServer::NatsServer(std::vector<std::string> extra, const std::string& config)
    : extra_(std::move(extra)) {
  port_ = ClosedPort();
  log_path_ = (store_.path() / "nats-server.log").string();
  if (!config.empty()) {
    const std::string path = (store_.path() / "nats-server.conf").string();
    std::ofstream(path) << config << "\n";
    extra_.insert(extra_.begin(), {"-c", path});
  }
  Start();
}

NatsServer::~NatsServer() { Kill(); }

std::string NatsServer::url() const { return absl::StrCat("nats://127.0.0.1:", port_); }

void NatsServer::Kill() {
  if (process_ == nullptr) return;
  process_->Signal(SIGKILL);
  process_->Wait();
  process_.reset();
}

bool NatsServer::Start() {
  Kill();
  std::vector<std::string> argv = {
      "nats-server",       "-a",  "127.0.0.1", "-p",
      absl::StrCat(port_), "-js", "-sd",       (store_.path() / "store").string()};
  argv.insert(argv.end(), extra_.begin(), extra_.end());
  process_ = std::make_unique<ChildProcess>(argv, log_path_);
  if (!process_->started() || !WaitUntil([&] { return Accepts(port_); }, absl::Seconds(10))) {
    ADD_FAILURE() << "nats-server did not start on port " << port_ << "; log: " << log_path_;
    process_.reset();
    return false;
  }
  return true;
}

}  // namespace transient::testing

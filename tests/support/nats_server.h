// A real nats-server (Debian's nats-server 2.9) for the tests of the NATS publisher and
// consumers: JetStream on, its store in a scratch directory, on a loopback port chosen at run
// time; killed and started again on the same port and store, to test a server that goes away.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tests/support/scratch_directory.h"
#include "tests/support/subprocess.h"

namespace transient::testing {

class NatsServer {
 public:
  // `extra`: more command-line options (e.g. {"--user", "u", "--pass", "p"}); `config`: the
  // text of a configuration file for what has no option (e.g. "max_payload: 65536"). Starts it
  // and waits until it accepts connections; running() says whether it does.
  explicit NatsServer(std::vector<std::string> extra = {}, const std::string& config = "");
  ~NatsServer();

  bool running() const { return process_ != nullptr; }
  std::string url() const;  // nats://127.0.0.1:PORT
  int port() const { return port_; }
  // SIGKILL, as a crash or a pulled cable would end it.
  void Kill();
  // Starts it again on the same port and store; false when it does not accept connections
  // within 10 s.
  bool Start();
  const std::string& log_path() const { return log_path_; }

 private:
  ScratchDirectory store_;
  std::vector<std::string> extra_;
  int port_ = 0;
  std::string log_path_;
  std::unique_ptr<ChildProcess> process_;
};

}  // namespace transient::testing

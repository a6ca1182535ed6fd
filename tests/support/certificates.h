// Certificates for the tests of TLS, made by openssl(1) at run time: two CAs, a server's
// certificate (for 127.0.0.1 and localhost) and a client's signed by the first, and a client's
// signed by the second. Shared by the daemon's and the NATS tests.
#pragma once

#include <sys/stat.h>

#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/subprocess.h"

namespace transient::testing {

// Files: File("ca", "pem"), File("server", "key"), ... for ca, other-ca, server, client,
// stranger; keys mode 0600 as openssl writes them.
class Certificates {
 public:
  Certificates() {
    for (const char* ca : {"ca", "other-ca"}) {
      Run({"openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
           "-nodes", "-days", "2", "-subj", absl::StrCat("/CN=transient test ", ca), "-keyout",
           File(ca, "key"), "-out", File(ca, "pem")});
    }
    Sign("server", "ca", "subjectAltName=IP:127.0.0.1,DNS:localhost");
    Sign("client", "ca", "");
    Sign("stranger", "other-ca", "");
  }

  std::string File(const std::string& name, const std::string& kind) const {
    return dir_.File(absl::StrCat(name, ".", kind));
  }
  bool ok() const { return ok_; }

 private:
  void Run(const std::vector<std::string>& argv) {
    const transient::testing::ProcessResult result = RunProcess(argv);
    if (result.exit_code != 0) {
      ok_ = false;
      ADD_FAILURE() << argv[0] << " " << argv[1] << " exited " << result.exit_code << ": "
                    << result.err;
    }
  }
  void Sign(const std::string& name, const std::string& ca, const std::string& extension) {
    Run({"openssl", "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
         "-subj", absl::StrCat("/CN=", name), "-keyout", File(name, "key"), "-out",
         File(name, "csr")});
    std::vector<std::string> argv = {"openssl",
                                     "x509",
                                     "-req",
                                     "-in",
                                     File(name, "csr"),
                                     "-CA",
                                     File(ca, "pem"),
                                     "-CAkey",
                                     File(ca, "key"),
                                     "-CAcreateserial",
                                     "-days",
                                     "2",
                                     "-out",
                                     File(name, "pem")};
    if (!extension.empty()) {
      std::ofstream(File(name, "ext")) << extension << "\n";
      argv.insert(argv.end(), {"-extfile", File(name, "ext")});
    }
    Run(argv);
  }

  ScratchDirectory dir_;
  bool ok_ = true;
};

}  // namespace transient::testing

// fork + setgid/setuid(nobody) for permission checks under root.
#include "tests/support/unprivileged.h"

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>

namespace transient::testing {

std::string RunUnprivileged(const std::function<bool()>& check) {
  if (::geteuid() != 0) return check() ? "" : "the check failed";
  const pid_t child = ::fork();
  if (child < 0) return "fork failed";
  if (child == 0) {
    constexpr uid_t kNobody = 65534;
    if (::setgid(kNobody) != 0 || ::setuid(kNobody) != 0) ::_exit(3);
    ::_exit(check() ? 0 : 1);
  }
  int status = 0;
  if (::waitpid(child, &status, 0) != child || !WIFEXITED(status)) return "the child crashed";
  switch (WEXITSTATUS(status)) {
    case 0: return "";
    case 3: return "could not drop to user nobody";
    default: return "the check failed";
  }
}

void AllowOthersIn(const std::string& directory) {
  using std::filesystem::perms;
  std::filesystem::permissions(directory, perms::others_exec, std::filesystem::perm_options::add);
}

}  // namespace transient::testing

// Checks that need an unprivileged process: root reads and writes whatever the permission bits
// say, so a test of "cannot read" or "cannot write" runs its check in a forked child that has
// dropped to user nobody when the test runs as root (CI does), and in-process otherwise.
#pragma once

#include <functional>
#include <string>

namespace transient::testing {

// Runs `check` (true: as expected) without root's privileges; returns "" when it held, or what
// went wrong ("the check failed", "could not drop to user nobody"). Files the check touches
// must be reachable by others (see AllowOthersIn).
std::string RunUnprivileged(const std::function<bool()>& check);

// Gives others search permission on `directory` (and read on nothing else), so that the
// unprivileged child can reach the files the test prepared there.
void AllowOthersIn(const std::string& directory);

}  // namespace transient::testing

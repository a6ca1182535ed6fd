// Loopback ports for tests of the network code: one that nothing listens on.
#pragma once

namespace transient::testing {

// A loopback TCP port that nothing listens on: bound, read and closed again, so a connection
// to 127.0.0.1:port is refused (until another process happens to take it, which the kernel's
// port allocation makes unlikely for the length of a test).
int ClosedPort();

}  // namespace transient::testing

// Where transientd listens unless told otherwise, and where its clients look first (the daemon's
// --listen, `transient client --connect`, the OpenNI2 driver's transient:// device), and which
// listening addresses only this machine reaches (the daemon's and the web gateway's rules).
#pragma once

#include <string>

namespace transient::wire {

inline constexpr char kDefaultAddress[] = "127.0.0.1:50051";

// Whether the host of `listen` (host:port, [v6]:port or unix:PATH) is this machine only:
// 127.0.0.0/8, ::1, localhost, or a Unix socket. Anything else, 0.0.0.0 and [::] included, is
// reachable from other machines.
bool IsLoopback(const std::string& listen);

}  // namespace transient::wire

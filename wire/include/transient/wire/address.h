// Where transientd listens unless told otherwise, and where its clients look first (the daemon's
// --listen, `transient client --connect`, the OpenNI2 driver's transient:// device).
#pragma once

namespace transient::wire {

inline constexpr char kDefaultAddress[] = "127.0.0.1:50051";

}  // namespace transient::wire

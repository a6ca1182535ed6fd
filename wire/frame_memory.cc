#include "transient/wire/frame_memory.h"

#include <malloc.h>

namespace transient::wire {

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TRANSIENT_WIRE_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define TRANSIENT_WIRE_ASAN 1
#endif

absl::Status KeepFreedFrameMemory() {
#ifdef TRANSIENT_WIRE_ASAN
  return absl::OkStatus();
#else
  constexpr int kMmapThreshold = 32 << 20;  // HEAP_MAX_SIZE / 2 on 64 bits: mallopt's largest
  constexpr int kTrimThreshold = 256 << 20;
  if (mallopt(M_MMAP_THRESHOLD, kMmapThreshold) != 1 ||
      mallopt(M_TRIM_THRESHOLD, kTrimThreshold) != 1) {
    return absl::InternalError(
        "the C library refused the heap's thresholds (mallopt): freed frame buffers go back to "
        "the kernel and are faulted in again, which costs latency");
  }
  return absl::OkStatus();
#endif
}

}  // namespace transient::wire

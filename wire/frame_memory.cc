#include "transient/wire/frame_memory.h"

#include <malloc.h>

namespace transient::wire {

absl::Status KeepFreedFrameMemory() {
#ifdef TRANSIENT_ADDRESS_SANITIZER
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

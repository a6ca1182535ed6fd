// The heap of a process that sends or receives frames at a camera's rate: a frame's products,
// their encodings and gRPC's message buffers are megabytes each (5 MB of slices at 163x120,
// 78 MB at 640x480), allocated and freed every frame.
#pragma once

#include "absl/status/status.h"

// Defined (to 1) where the code is compiled under AddressSanitizer, whose allocator replaces
// glibc's: the heap's thresholds below do not apply there, and memory is ASan's to count.
#if defined(__SANITIZE_ADDRESS__)  // GCC
#define TRANSIENT_ADDRESS_SANITIZER 1
#elif defined(__has_feature)  // Clang
#if __has_feature(address_sanitizer)
#define TRANSIENT_ADDRESS_SANITIZER 1
#endif
#endif

namespace transient::wire {

// Makes glibc keep the memory that a frame frees for the next frame's buffers instead of
// handing it back to the kernel, which the next frame then faults in page by page. By default
// glibc unmaps a freed block above its mmap threshold and trims a heap whose free top exceeds
// its trim threshold, both starting at 128 KiB and rising as large blocks are freed, so what a
// run keeps depends on the order of its first frees: the latency of runs of the same daemon
// differed by 2x, and at 163x120 with 64 slices the slow ones took 264,000 page faults in 8 s
// against 18,500 with this call (docs/speed.md). It sets the mmap threshold to 32 MiB (glibc's
// largest) and the trim threshold to 256 MiB; the heap keeps at most what the process had
// allocated at its peak. Process-wide: call it once, first thing in main. A no-op under
// AddressSanitizer, whose allocator is its own. Internal when the C library refuses.
absl::Status KeepFreedFrameMemory();

}  // namespace transient::wire

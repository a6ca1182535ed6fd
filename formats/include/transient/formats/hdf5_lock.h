// The one process-wide lock around HDF5. Debian's HDF5 is built without thread safety: two
// threads inside the library at once corrupt its global state (identifier tables, the metadata
// cache, the error stack) even when they work on different files. So every multi-threaded
// program that uses this component, or HDF5 directly, holds Hdf5Mutex() around each HDF5 call
// and around each call into formats/ (readers, writers, replay sources); a single-threaded
// program (the `transient` tool) need not. Annotate what must run under it with
// ABSL_EXCLUSIVE_LOCKS_REQUIRED(Hdf5Mutex()) so that Clang's -Wthread-safety checks the callers.
#pragma once

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

namespace transient {

// The same mutex in every call, from every thread; created on first use and never destroyed,
// so that threads still running at exit may take it.
absl::Mutex& Hdf5Mutex();

}  // namespace transient

// The process-wide HDF5 mutex (hdf5_lock.h).
#include "transient/formats/hdf5_lock.h"

namespace transient {

absl::Mutex& Hdf5Mutex() {
  // Leaked on purpose: a static object would be destroyed at exit under threads that may
  // still hold it.
  static absl::Mutex* const mutex = new absl::Mutex();
  return *mutex;
}

}  // namespace transient

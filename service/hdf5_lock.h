// The daemon's lock around HDF5 (Debian's build is not thread-safe): every HDF5 call of the
// daemon (replay reads, recordings, calibration files) holds Hdf5Mutex().
#pragma once

#include "absl/synchronization/mutex.h"

namespace transient::service {

absl::Mutex& Hdf5Mutex();

}  // namespace transient::service

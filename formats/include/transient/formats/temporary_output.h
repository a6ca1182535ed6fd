// Transitional: the former name of AtomicOutput (atomic_output.h), for the call sites outside
// formats/ that still spell it (tools/transient/capture_commands.cc, point_cloud.cc). Include
// atomic_output.h instead; this header goes once they do.
#pragma once

#include "transient/formats/atomic_output.h"

namespace transient {

using TemporaryOutput = AtomicOutput;

}  // namespace transient

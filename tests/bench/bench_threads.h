// Thread arguments of the benchmarks in this directory (transient_bench).
#pragma once

#include <benchmark/benchmark.h>

#include "transient/reconstruct/kernels.h"

namespace transient {

// The optimized kernels, on the number of threads that argument `index` of the benchmark holds
// (KernelOptions).
inline void UseThreadsArgument(const benchmark::State& state, int index) {
  SetKernelOptions(
      {.kind = KernelKind::kOptimized, .threads = static_cast<int>(state.range(index))});
}

// One argument, threads: 1 and 2, rates per wall-clock second (not per main-thread CPU second).
inline void OnOneAndTwoThreads(benchmark::internal::Benchmark* b) {
  b->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();
}

}  // namespace transient

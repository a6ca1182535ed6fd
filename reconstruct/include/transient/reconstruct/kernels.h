// The two implementations behind the image-level API of reconstructor.h, with the same
// signatures: `reference` (plain scalar double loops, the oracle) and `optimized` (shared
// trigonometric tables, SIMD over pixels, threads over rows). The functions of
// reconstructor.h call the kind chosen with SetKernelOptions (optimized by default); tests
// and benchmarks call both directly.
#pragma once

#include <span>

#include "transient/reconstruct/reconstructor.h"

namespace transient {

enum class KernelKind { kReference, kOptimized };

struct KernelOptions {
  KernelKind kind = KernelKind::kOptimized;
  int threads = 0;  // optimized kernels: worker threads; 0 = one per core
};

// Process-wide choice; set it before reconstruction starts, not concurrently with it.
void SetKernelOptions(const KernelOptions& options);
KernelOptions GetKernelOptions();
// The OpenMP threads an optimized kernel uses: GetKernelOptions().threads, or one per core.
int KernelThreads();

#define TRANSIENT_KERNEL_DECLARATIONS                                                              \
  void Solve(const MomentImage& moments, const SolveOptions& options, SolvedImage* solved);        \
  PisarenkoImage EstimatePisarenko(const SolvedImage& solved);                                     \
  void DensitySlices(const SolvedImage& solved, std::span<const double> phases,                    \
                     std::span<float> out);                                                        \
  void CumulativeSlices(const SolvedImage& solved, std::span<const double> phases,                 \
                        std::span<float> out);                                                     \
  void BoundSlices(const SolvedImage& solved, double r, std::span<const double> phases,            \
                   std::span<float> lower, std::span<float> upper);                                \
  void MeseRange(const SolvedImage& solved, const RangeOptions& options, std::span<float> range_m, \
                 std::span<uint8_t> flags);

namespace reference {
TRANSIENT_KERNEL_DECLARATIONS
inline SolvedImage Solve(const MomentImage& moments, const SolveOptions& options) {
  SolvedImage solved;
  reference::Solve(moments, options, &solved);  // qualified: no ADL to transient::Solve
  return solved;
}
void PisarenkoRange(const PisarenkoImage& pisarenko, const RangeOptions& options,
                    std::span<float> range_m, std::span<uint8_t> flags);
void SeparateDirectIndirect(const PisarenkoImage& pisarenko, double threshold,
                            std::span<float> direct, std::span<float> indirect);
}  // namespace reference

namespace optimized {
TRANSIENT_KERNEL_DECLARATIONS
inline SolvedImage Solve(const MomentImage& moments, const SolveOptions& options) {
  SolvedImage solved;
  optimized::Solve(moments, options, &solved);
  return solved;
}
}  // namespace optimized

#undef TRANSIENT_KERNEL_DECLARATIONS

}  // namespace transient

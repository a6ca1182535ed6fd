// Filtering of a 640 x 480 moment depth map (4 channels b1..b4): the separable Gaussian's fast
// path at sigma = 1, 2, 4 px on 1 and 2 threads, and the summed-area table's build. Issue 7's
// budget: moment map + Gaussian + quantization <= 5 ms per frame on two cores.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "bench_threads.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/moment_filter.h"

namespace transient {
namespace {

constexpr ImageGeometry kGeometry{640, 480};
constexpr int kChannels = 4;

// Power moments z, z^2, z^3, z^4 of random normalised depths z in [-1, 1].
std::vector<float> MomentMap() {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int64_t pixels = kGeometry.pixel_count();
  std::vector<float> planes(static_cast<size_t>(kChannels * pixels));
  for (int64_t p = 0; p < pixels; ++p) {
    const float z = u(rng);
    float power = 1.0f;
    for (int k = 0; k < kChannels; ++k) planes[static_cast<size_t>(k * pixels + p)] = power *= z;
  }
  return planes;
}

// Arguments: sigma in px, threads.
void BM_GaussianMomentFilter(benchmark::State& state) {
  UseThreadsArgument(state, 1);
  const std::vector<float> in = MomentMap();
  std::vector<float> out(in.size());
  absl::StatusOr<GaussianMomentFilter> filter =
      GaussianMomentFilter::Create(static_cast<double>(state.range(0)), kGeometry, kChannels);
  if (!filter.ok()) {
    state.SkipWithError(filter.status().ToString().c_str());
    return;
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(filter->Apply(in, out));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kGeometry.pixel_count());
}
BENCHMARK(BM_GaussianMomentFilter)
    ->ArgNames({"sigma", "threads"})
    ->ArgsProduct({{1, 2, 4}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Argument: threads.
void BM_SummedAreaTableBuild(benchmark::State& state) {
  UseThreadsArgument(state, 0);
  const std::vector<float> in = MomentMap();
  for (auto _ : state) {
    benchmark::DoNotOptimize(SummedAreaTable::Build(kGeometry, kChannels, in));
  }
  state.SetItemsProcessed(state.iterations() * kGeometry.pixel_count());
}
BENCHMARK(BM_SummedAreaTableBuild)->Apply(OnOneAndTwoThreads)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace transient

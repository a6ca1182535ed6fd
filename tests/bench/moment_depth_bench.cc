// The moment depth map per frame at 640 x 480 (issue 7's budget: <= 5 ms on two cores):
// MomentDepthMapBuilder::Build in both formats; and OcclusionFraction queries per second
// (target 1e8), one at a time and batched (OcclusionFractions).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "bench_threads.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/reconstruct/power_moments.h"

namespace transient {
namespace {

constexpr ImageGeometry kGeometry{640, 480};
constexpr DepthNormalisation kRange{.near_m = 0.5, .far_m = 4.5};

// A depth image of a few planes at different depths with 1% invalid (NaN) pixels.
std::vector<float> DepthImage() {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> depth(static_cast<size_t>(kGeometry.pixel_count()));
  for (int y = 0; y < kGeometry.height; ++y) {
    for (int x = 0; x < kGeometry.width; ++x) {
      float d = 1.0f + 3.0f * static_cast<float>((x / 80 + y / 60) % 5) / 4.0f;
      if (u(rng) < 0.01f) d = NAN;
      depth[static_cast<size_t>(y * kGeometry.width + x)] = d;
    }
  }
  return depth;
}

// MomentDepthMapBuilder::Build, the per-frame path of the MOMENT_DEPTH product: depth ->
// coverage-weighted power moments (float) -> GaussianMomentFilter -> division by the filtered
// coverage and quantization. Arguments: format (0 = kOptimized64, 1 = kFloat128), sigma in px,
// threads.
void BM_MomentDepthFrame(benchmark::State& state) {
  const MomentMapFormat format =
      state.range(0) == 0 ? MomentMapFormat::kOptimized64 : MomentMapFormat::kFloat128;
  UseThreadsArgument(state, 2);
  const std::vector<float> depth = DepthImage();
  absl::StatusOr<MomentDepthMapBuilder> builder = MomentDepthMapBuilder::Create(
      kGeometry,
      {.normalisation = kRange, .sigma_px = static_cast<double>(state.range(1)), .format = format});
  if (!builder.ok()) {
    state.SkipWithError(builder.status().ToString().c_str());
    return;
  }
  MomentDepthMap map;
  for (auto _ : state) {
    const absl::Status status = builder->Build(depth, &map);
    if (!status.ok()) {
      state.SkipWithError(status.ToString().c_str());
      return;
    }
    benchmark::DoNotOptimize(map.quantized.data());
    benchmark::DoNotOptimize(map.moments.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kGeometry.pixel_count());
}
BENCHMARK(BM_MomentDepthFrame)
    ->ArgNames({"float128", "sigma", "threads"})
    ->ArgsProduct({{0, 1}, {1, 2}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Filtered moment vectors of 1..4 random surfaces (footprint mixtures) and random queries.
struct Queries {
  std::vector<PowerMomentsF> moments;
  std::vector<float> z_f;
};
Queries MakeQueries() {
  constexpr int kCount = 4096;  // fits in L1/L2: measures the arithmetic, not memory
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), w(0.05f, 1.0f);
  Queries q;
  for (int i = 0; i < kCount; ++i) {
    PowerMomentsF b{};
    float total = 0.0f;
    for (int l = 0; l <= i % 4; ++l) {
      const float z = u(rng), weight = w(rng);
      float power = 1.0f;
      for (int j = 0; j < kPowerMomentCount; ++j, power *= z) b[j] += weight * power;
      total += weight;
    }
    for (float& v : b) v /= total;
    q.moments.push_back(b);
    q.z_f.push_back(u(rng));
  }
  return q;
}

void BM_OcclusionFraction(benchmark::State& state) {
  const Queries q = MakeQueries();
  const size_t n = q.moments.size();
  for (auto _ : state) {
    for (size_t i = 0; i < n; ++i)
      benchmark::DoNotOptimize(OcclusionFraction(q.moments[i], q.z_f[i]));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_OcclusionFraction);

// The batched form (AVX2 + FMA, eight queries per instruction), one thread.
void BM_OcclusionFractions(benchmark::State& state) {
  const Queries q = MakeQueries();
  std::vector<float> out(q.moments.size());
  for (auto _ : state) {
    OcclusionFractions(q.moments, q.z_f, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * q.moments.size()));
}
BENCHMARK(BM_OcclusionFractions);

}  // namespace
}  // namespace transient

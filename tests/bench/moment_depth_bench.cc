// The moment depth map per frame at 640 x 480 (issue 7's budget: <= 5 ms on two cores): depth
// image -> power moments b1..b4 (float planes) -> GaussianMomentFilter -> optimized 64-bit
// quantization (eq. 4.4) of every pixel; and OcclusionFraction queries per second (target 1e8).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/moment_filter.h"
#include "transient/reconstruct/moment_quantization.h"
#include "transient/reconstruct/power_moments.h"

namespace transient {
namespace {

constexpr ImageGeometry kGeometry{640, 480};
constexpr int kChannels = 4;
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

// Argument: sigma in px, threads.
void BM_MomentDepthFrame(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  SetKernelOptions({.kind = KernelKind::kOptimized, .threads = threads});
  const std::vector<float> depth = DepthImage();
  const int64_t pixels = kGeometry.pixel_count();
  std::vector<float> planes(static_cast<size_t>(kChannels * pixels)), filtered(planes.size());
  std::vector<QuantizedMoments64> quantized(static_cast<size_t>(pixels));
  absl::StatusOr<GaussianMomentFilter> filter =
      GaussianMomentFilter::Create(static_cast<double>(state.range(0)), kGeometry, kChannels);
  if (!filter.ok()) {
    state.SkipWithError(filter.status().ToString().c_str());
    return;
  }
  const float scale = static_cast<float>(2.0 / (kRange.far_m - kRange.near_m));
  const float offset = static_cast<float>(-1.0 - 2.0 * kRange.near_m / (kRange.far_m - kRange.near_m));
  for (auto _ : state) {
    // Moments in float; an invalid pixel takes the far plane (z̄ = 1), which occludes nothing.
#pragma omp parallel for num_threads(threads)
    for (int64_t p = 0; p < pixels; ++p) {
      const float d = depth[static_cast<size_t>(p)];
      const float z = d == d ? std::clamp(std::fma(d, scale, offset), -1.0f, 1.0f) : 1.0f;
      const float z2 = z * z;
      planes[static_cast<size_t>(p)] = z;
      planes[static_cast<size_t>(pixels + p)] = z2;
      planes[static_cast<size_t>(2 * pixels + p)] = z2 * z;
      planes[static_cast<size_t>(3 * pixels + p)] = z2 * z2;
    }
    benchmark::DoNotOptimize(filter->Apply(planes, filtered));
#pragma omp parallel for num_threads(threads)
    for (int64_t p = 0; p < pixels; ++p) {
      const PowerMoments b = {1.0, filtered[static_cast<size_t>(p)],
                              filtered[static_cast<size_t>(pixels + p)],
                              filtered[static_cast<size_t>(2 * pixels + p)],
                              filtered[static_cast<size_t>(3 * pixels + p)]};
      EncodeOptimized64(b, &quantized[static_cast<size_t>(p)]);
    }
    benchmark::DoNotOptimize(quantized.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * pixels);
}
BENCHMARK(BM_MomentDepthFrame)
    ->ArgNames({"sigma", "threads"})
    ->ArgsProduct({{1, 2}, {1, 2}})
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
    for (size_t i = 0; i < n; ++i) benchmark::DoNotOptimize(OcclusionFraction(q.moments[i], q.z_f[i]));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_OcclusionFraction);

}  // namespace
}  // namespace transient

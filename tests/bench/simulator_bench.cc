// Throughput of the simulator (pace=fast): raw frames per second and their ratio to real time
// (1 / frame period), which must exceed 1 at the thesis's sensor size for the default scene and
// for `video` (simulator.h); and its sensor's noise against its reference. Run:
// build-*/tests/bench/transient_bench --benchmark_filter='Simulator|Sensor'.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/time/clock.h"
#include "sim/sensor.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/simulator.h"

namespace transient {
namespace {

const char* const kUris[] = {
    "sim:mirrors?pace=fast",                       // default scene, physical noise
    "sim:video?pace=fast",                         // re-rendered every cycle
    "sim:corner?pace=fast",                        // continuous returns
    "sim:mirrors?pace=fast&width=640&height=480",  // the largest sensor
    "sim:video?pace=fast&width=640&height=480",
};

void BM_SimulatorRawFrames(benchmark::State& state) {
  const std::string uri = kUris[state.range(0)];
  state.SetLabel(uri);
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(uri);
  if (!options.ok()) {
    state.SkipWithError(std::string(options.status().message()).c_str());
    return;
  }
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSimulator(*options);
  if (!source.ok() || !(*source)->Start().ok()) {
    state.SkipWithError("cannot open the simulator");
    return;
  }
  RawFrame frame;
  const absl::Time begin = absl::Now();
  for (auto _ : state) {
    if (!(*source)->Next(absl::Seconds(10), &frame).ok()) {
      state.SkipWithError("Next failed");
      break;
    }
    benchmark::DoNotOptimize(frame.pixels.data());
  }
  const double seconds = absl::ToDoubleSeconds(absl::Now() - begin);
  const double frames = static_cast<double>(state.iterations());
  state.counters["frames/s"] = benchmark::Counter(frames, benchmark::Counter::kIsRate);
  // Frames per second times the frame period: how many times faster than the camera it
  // simulates (a plain ratio, so not a benchmark rate).
  state.counters["x_realtime"] = frames / seconds * (*source)->camera().frame_period_s;
}
BENCHMARK(BM_SimulatorRawFrames)->DenseRange(0, 4)->UseRealTime()->Unit(benchmark::kMillisecond);

// The sensor's noise and ADC alone (the default scene's physical noise, 12-bit ADC) on a VGA
// frame's 18 exposures at m = 4 (16 modulated, 2 not), one thread: Sensor::ReadRow (argument 0:
// in batches, in vector registers) against its pixel-by-pixel reference (1).
void BM_SensorVgaFrame(benchmark::State& state) {
  const bool reference = state.range(0) == 1;
  state.SetLabel(reference ? "ReadRowReference" : "ReadRow");
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri("sim:mirrors");
  if (!options.ok()) {
    state.SkipWithError(std::string(options.status().message()).c_str());
    return;
  }
  const sim::Sensor sensor(*options);
  constexpr int kWidth = 640, kHeight = 480, kExposures = 18, kModulated = 16;
  std::vector<float> light(kWidth * kHeight), differential(kWidth * kHeight), out(kWidth * kHeight);
  for (int i = 0; i < kWidth * kHeight; ++i) {  // 2000-3000 electrons, every phase
    light[i] = 2000.0f + static_cast<float>(i % 1000);
    differential[i] = light[i] * std::sin(0.01f * static_cast<float>(i));
  }
  for (auto _ : state) {
    for (int e = 0; e < kExposures; ++e) {
      sim::TapInput input;
      input.light = light.data();
      input.differential = differential.data();
      input.modulated = e < kModulated;
      for (int v = 0; v < kHeight; ++v) {
        const int64_t offset = int64_t{v} * kWidth;
        if (reference) {
          sensor.ReadRowReference(input, offset, kWidth, e, v, out.data() + offset);
        } else {
          sensor.ReadRow(input, offset, kWidth, e, v, out.data() + offset);
        }
      }
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["pixels/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * kExposures * kWidth * kHeight,
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SensorVgaFrame)->DenseRange(0, 1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace transient

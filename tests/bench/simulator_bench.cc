// Throughput of the simulator (pace=fast): raw frames per second and their ratio to real time
// (1 / frame period), which must exceed 1 at the thesis's sensor size for the default scene and
// for `video` (simulator.h). Run: build-*/tests/bench/transient_bench --benchmark_filter=Simulator
#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "absl/time/clock.h"
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

}  // namespace
}  // namespace transient

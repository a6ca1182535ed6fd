// Throughput of the reference and the optimized kernels in one run. Arguments: m, kernel kind
// (0 = reference, 1 = optimized) and threads of the optimized kind. `transient bench` prints
// the same measurements side by side with their ratio. Run: make bench.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "bench_threads.h"
#include "tools/transient/commands/bench_command.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/simulator.h"
#include "transient/reconstruct/cycle_assembler.h"
#include "transient/reconstruct/demodulation.h"
#include "transient/reconstruct/frame_pipeline.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/phase_unwrapping.h"
#include "transient/reconstruct/smoothing.h"

namespace transient {
namespace {

// The frame of `transient bench` at the thesis's sensor size (pmd 19k, 163 x 120).
MomentImage MakeFrame(int m) { return tools::MakeBenchFrame({163, 120}, m); }

// Selects the kernels of a benchmark from its arguments (m, kind, threads).
void UseKernels(const benchmark::State& state) {
  SetKernelOptions({.kind = state.range(1) == 0 ? KernelKind::kReference : KernelKind::kOptimized,
                    .threads = static_cast<int>(state.range(2))});
}

// m = 3, 4, 8 for the reference, and for the optimized kind on 1 and 2 threads.
void Arguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"m", "optimized", "threads"});
  b->UseRealTime();  // threads: rates per wall-clock second, not per main-thread CPU second
  for (int m : {3, 4, 8}) {
    b->Args({m, 0, 1});
    b->Args({m, 1, 1});
    b->Args({m, 1, 2});
  }
}

void BM_Solve(benchmark::State& state) {
  const MomentImage image = MakeFrame(static_cast<int>(state.range(0)));
  UseKernels(state);
  // One SolvedImage reused from frame to frame, as a stream (and `transient bench`) does: a new
  // one every iteration timed the allocator and its page faults too (once, on two threads,
  // 10.2 ms a frame instead of 0.37).
  SolvedImage solved;
  for (auto _ : state) {
    Solve(image, SolveOptions{}, &solved);
    benchmark::DoNotOptimize(solved.q_real.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * image.geometry.pixel_count());
  state.counters["pixels/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * image.geometry.pixel_count()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Solve)->Apply(Arguments)->Unit(benchmark::kMillisecond);

void BM_DensitySlices(benchmark::State& state) {
  const MomentImage image = MakeFrame(static_cast<int>(state.range(0)));
  UseKernels(state);
  const SolvedImage solved = Solve(image, SolveOptions{});
  const auto phases = UniformPhases(256);
  std::vector<float> out(phases.size() * image.geometry.pixel_count());
  for (auto _ : state) {
    DensitySlices(solved, phases, out);
    benchmark::ClobberMemory();
  }
  state.counters["evaluations/s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * out.size()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DensitySlices)->Apply(Arguments)->Unit(benchmark::kMillisecond);

void BM_CumulativeSlices(benchmark::State& state) {
  const MomentImage image = MakeFrame(static_cast<int>(state.range(0)));
  UseKernels(state);
  const SolvedImage solved = Solve(image, SolveOptions{});
  const auto phases = UniformPhases(64);
  std::vector<float> out(phases.size() * image.geometry.pixel_count());
  for (auto _ : state) {
    CumulativeSlices(solved, phases, out);
    benchmark::ClobberMemory();
  }
  state.counters["evaluations/s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * out.size()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CumulativeSlices)->Apply(Arguments)->Unit(benchmark::kMillisecond);

// MESE range of `image`, solved once, with the kernels of the benchmark's arguments.
void TimeMeseRange(benchmark::State& state, const MomentImage& image) {
  UseKernels(state);
  const SolvedImage solved = Solve(image, SolveOptions{});
  const int64_t pixels = image.geometry.pixel_count();
  std::vector<float> range(pixels);
  std::vector<uint8_t> flags(pixels);
  for (auto _ : state) {
    MeseRange(solved, RangeOptions{}, range, flags);
    benchmark::ClobberMemory();
  }
  state.counters["pixels/s"] = benchmark::Counter(static_cast<double>(state.iterations() * pixels),
                                                  benchmark::Counter::kIsRate);
}

void BM_MeseRange(benchmark::State& state) {
  TimeMeseRange(state, MakeFrame(static_cast<int>(state.range(0))));
}
BENCHMARK(BM_MeseRange)->Apply(Arguments)->Unit(benchmark::kMillisecond);

// One capture cycle of a simulated camera, as the cycle assembler delivers it to the daemon.
struct SimulatedCycle {
  AcquisitionSchedule schedule;
  ImageGeometry geometry;
  std::vector<RawFrame> frames;
};

// The first complete cycle of the simulator at `uri`; an error message where it refuses.
absl::StatusOr<SimulatedCycle> FirstSimulatedCycle(const std::string& uri) {
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(uri);
  if (!options.ok()) return options.status();
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSimulator(*options);
  if (!source.ok()) return source.status();
  if (absl::Status status = (*source)->Start(); !status.ok()) return status;
  const AcquisitionSchedule& schedule = (*source)->schedule();
  const ImageGeometry geometry = (*source)->camera().geometry;
  absl::StatusOr<CycleAssembler> assembler = CycleAssembler::Create(schedule, geometry);
  if (!assembler.ok()) return assembler.status();
  RawFrame frame;
  for (int i = 0; i < 4 * schedule.raw_frames_per_frame(); ++i) {
    if (absl::Status status = (*source)->Next(absl::Seconds(10), &frame); !status.ok()) {
      return status;
    }
    absl::StatusOr<bool> complete = assembler->Add(std::move(frame));
    if (complete.ok() && *complete)
      return SimulatedCycle{schedule, geometry, assembler->TakeCycle()};
  }
  return absl::InternalError(absl::StrCat(uri, " gave no complete cycle"));
}

// The first frame of the simulated camera at `uri` (a `mirrors` scene: its physical noise),
// measured as the daemon measures it (demodulation and smoothing) with `measure`'s calibration.
// An error message where the simulator or the pipeline refuse.
absl::StatusOr<MomentImage> MeasuredFrame(const std::string& uri, const MeasureOptions& measure) {
  absl::StatusOr<SimulatedCycle> cycle = FirstSimulatedCycle(uri);
  if (!cycle.ok()) return cycle.status();
  absl::StatusOr<FramePipeline> pipeline =
      FramePipeline::Create(cycle->schedule, cycle->geometry, measure, SolveOptions{});
  if (!pipeline.ok()) return pipeline.status();
  MomentImage moments;
  if (absl::Status status = pipeline->Measure(cycle->frames, &moments); !status.ok()) {
    return status;
  }
  return moments;
}

// The first frame of the simulated camera's `mirrors` scene at 163 x 120, uncalibrated
// (MeasuredFrame): the data transientd reconstructs from sim:mirrors, noisier than MakeFrame's.
// Its pixels hold weak returns beside strong ones, whose peaks may pass by their light
// (MeseFirstReturn).
absl::StatusOr<MomentImage> SimulatedFrame(int m) {
  return MeasuredFrame(absl::StrCat("sim:mirrors?pace=fast&m=", m), MeasureOptions{});
}

// MESE range on SimulatedFrame.
void BM_MeseRangeSimulated(benchmark::State& state) {
  const absl::StatusOr<MomentImage> image = SimulatedFrame(static_cast<int>(state.range(0)));
  if (!image.ok()) {
    state.SkipWithError(std::string(image.status().message()).c_str());
    return;
  }
  TimeMeseRange(state, *image);
}
BENCHMARK(BM_MeseRangeSimulated)->Apply(Arguments)->Unit(benchmark::kMillisecond);

// The simulated camera's `mirrors` scene at 640 x 480, m = 4, measured (MeasuredFrame) with a
// calibration of its `calibration` scene, as in `bench_daemon.sh`'s calibrated replay (there of
// `transient calibrate`'s 20 takes, here of 4, to start faster): the corrected moments of a
// sparse scene lie on the boundary of the moment set, and most pixels need biasing's
// lambda_min. An error message where the simulator or the pipeline refuse.
absl::StatusOr<MomentImage> CalibratedVgaFrame() {
  const std::string size = "pace=fast&m=4&width=640&height=480";
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri("sim:calibration?" + size);
  if (!options.ok()) return options.status();
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSimulator(*options);
  if (!source.ok()) return source.status();
  absl::StatusOr<CalibrationCapture> calibration = CaptureCalibration(**source, 4);
  if (!calibration.ok()) return calibration.status();
  return MeasuredFrame(
      "sim:mirrors?" + size,
      MeasureOptions{.calibration = std::make_shared<const CalibrationTable>(calibration->table)});
}

// The solve of CalibratedVgaFrame, a calibrated camera's frame. Argument: threads.
void BM_SolveCalibrated(benchmark::State& state) {
  UseThreadsArgument(state, 0);
  const absl::StatusOr<MomentImage> image = CalibratedVgaFrame();
  if (!image.ok()) {
    state.SkipWithError(std::string(image.status().message()).c_str());
    return;
  }
  SolvedImage solved;
  Solve(*image, SolveOptions{}, &solved);  // untimed: the first call faults its buffers in
  for (auto _ : state) {
    Solve(*image, SolveOptions{}, &solved);
    benchmark::ClobberMemory();
  }
  state.counters["pixels/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * image->geometry.pixel_count()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SolveCalibrated)->Apply(OnOneAndTwoThreads)->Unit(benchmark::kMillisecond);

// The daemon's demodulation of one cycle of the simulated camera's `mirrors` scene at
// 640 x 480, m = 4, demodulated again and again in video mode (each cycle scored against the
// previous one and kept for the next; the same cycle, so no plane is filled). Argument:
// threads (KernelOptions).
void BM_Demodulate(benchmark::State& state) {
  UseThreadsArgument(state, 0);
  const absl::StatusOr<SimulatedCycle> cycle =
      FirstSimulatedCycle("sim:mirrors?pace=fast&m=4&width=640&height=480");
  absl::StatusOr<Demodulator> demodulator =
      cycle.ok() ? Demodulator::Create(cycle->schedule, cycle->geometry,
                                       DemodulationOptions{.video = true})
                 : absl::StatusOr<Demodulator>(cycle.status());
  if (!demodulator.ok()) {
    state.SkipWithError(std::string(demodulator.status().message()).c_str());
    return;
  }
  MomentImage moments;
  for (auto _ : state) {
    if (absl::Status status = demodulator->Demodulate(cycle->frames, &moments); !status.ok()) {
      state.SkipWithError(std::string(status.message()).c_str());
      return;
    }
  }
  state.counters["pixels/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * moments.geometry.pixel_count()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Demodulate)->Apply(OnOneAndTwoThreads)->Unit(benchmark::kMillisecond);

void BM_Pisarenko(benchmark::State& state) {
  const MomentImage image = MakeFrame(static_cast<int>(state.range(0)));
  UseKernels(state);
  const SolvedImage solved = Solve(image, SolveOptions{});
  for (auto _ : state) benchmark::DoNotOptimize(EstimatePisarenko(solved));
  state.counters["pixels/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * image.geometry.pixel_count()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Pisarenko)->Apply(Arguments)->Unit(benchmark::kMillisecond);

// `transient bench`'s VGA pipeline row (640 x 480, m = 4: solve; range, amplitude and 64
// density slices of the solved frame) one stage at a time, and whole. Arguments: the stage
// (0 solve, 1 range, 2 amplitude, 3 slices, 4 all) and threads of the optimized kernels.
void BM_VgaPipeline(benchmark::State& state) {
  const int stage = static_cast<int>(state.range(0));
  UseThreadsArgument(state, 1);
  const MomentImage image = tools::MakeBenchFrame({640, 480}, 4);
  const int64_t pixels = image.geometry.pixel_count();
  const std::vector<double> phases = UniformPhases(64);
  std::vector<float> range(pixels), amplitude(pixels), slices(phases.size() * pixels);
  std::vector<uint8_t> flags(pixels);
  SolvedImage solved;
  Solve(image, SolveOptions{}, &solved);
  for (auto _ : state) {
    if (stage == 0 || stage == 4) Solve(image, SolveOptions{}, &solved);
    if (stage == 1 || stage == 4) {
      flags = solved.flags;
      MeseRange(solved, RangeOptions{}, range, flags);
    }
    if (stage == 2 || stage == 4) Amplitude(solved, amplitude);
    if (stage == 3 || stage == 4) DensitySlices(solved, phases, slices);
    benchmark::ClobberMemory();
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_VgaPipeline)
    ->ArgNames({"stage", "threads"})
    ->ArgsProduct({{0, 1, 2, 3, 4}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The daemon's smoothing of a frame's moments (sigma 0.6 px, every plane) at 640 x 480, m = 4.
// Argument: threads (KernelOptions; the same arithmetic on any number).
void BM_GaussianSmooth(benchmark::State& state) {
  UseThreadsArgument(state, 0);
  const MomentImage frame = tools::MakeBenchFrame({640, 480}, 4);
  MomentImage image = frame;
  for (auto _ : state) {
    state.PauseTiming();
    image.real = frame.real;  // smoothed in place
    image.imag = frame.imag;
    state.ResumeTiming();
    benchmark::DoNotOptimize(GaussianSmooth(0.6, &image).ok());
  }
  state.counters["pixels/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * frame.geometry.pixel_count()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_GaussianSmooth)->Apply(OnOneAndTwoThreads)->Unit(benchmark::kMillisecond);

// Three-frequency phase unwrapping at the Kinect v2's size and harmonics (10, 2, 15 of 8 MHz):
// the depth cameras' range. Arguments: kernel kind (0: UnwrapPixel per pixel on one thread),
// threads.
void BM_UnwrapKinect(benchmark::State& state) {
  SetKernelOptions({.kind = state.range(0) == 0 ? KernelKind::kReference : KernelKind::kOptimized,
                    .threads = static_cast<int>(state.range(1))});
  const MomentImage image = tools::MakeBenchFrame({512, 424}, 15);
  UnwrapOptions options;
  options.base_frequency_hz = 8e6;
  options.harmonics = {10, 2, 15};
  std::vector<float> range, amplitude, confidence;
  std::vector<uint8_t> flags;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        UnwrapImage(image, options, &range, &amplitude, &confidence, &flags).ok());
  }
  state.counters["pixels/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * image.geometry.pixel_count()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_UnwrapKinect)
    ->ArgNames({"optimized", "threads"})
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({1, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace transient

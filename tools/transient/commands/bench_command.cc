// Measurements of `transient bench`. Each row times the reference kernel and the optimized
// kernel on the same frame in the same run; the reference runs single-threaded (it has no
// threads), the optimized one with the row's thread count. The machine's rows time two loops on
// one thread and on more, at the run's start and end.
#include "tools/transient/commands/bench_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <random>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tools/transient/common/json_text.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/phase_unwrapping.h"

namespace transient::tools {
namespace {

// Seconds per call of `run`, repeated until `min_seconds` have passed (at least once).
double SecondsPerCall(const std::function<void()>& run, double min_seconds) {
  using Clock = std::chrono::steady_clock;
  int calls = 0;
  const auto start = Clock::now();
  double elapsed = 0.0;
  do {
    run();
    ++calls;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  } while (elapsed < min_seconds);
  return elapsed / calls;
}

// Times `run` with the reference kernels and with the optimized ones at each thread count.
void Measure(const BenchArgs& args, const std::string& kernel, int m, ImageGeometry geometry,
             const std::string& unit, double units_per_call, const std::function<void()>& run,
             std::vector<BenchRow>* rows, void (*progress)(const BenchRow&)) {
  SetKernelOptions({.kind = KernelKind::kReference});
  const double reference = units_per_call / SecondsPerCall(run, args.min_seconds);
  for (int threads : args.threads) {
    SetKernelOptions({.kind = KernelKind::kOptimized, .threads = threads});
    const double optimized = units_per_call / SecondsPerCall(run, args.min_seconds);
    rows->push_back({.kernel = kernel,
                     .order = m,
                     .width = geometry.width,
                     .height = geometry.height,
                     .threads = threads,
                     .unit = unit,
                     .reference = reference,
                     .optimized = optimized});
    if (progress != nullptr) progress(rows->back());
  }
  SetKernelOptions({});
}

// `work(t)` for t = 0..threads-1, each on its own thread (t = 0 on the caller's); the threads
// are joined however `work` or a thread's start ends.
void OnThreads(int threads, const std::function<void(int)>& work) {
  std::vector<std::jthread> others;
  for (int t = 1; t < threads; ++t) others.emplace_back(work, t);
  work(0);
}

// Sixteen independent chains of multiply-adds, two to a variable of two doubles (an SSE2
// register, the tool's instruction set): enough to keep the units busy whatever their latency,
// and nothing read or written in the loop (an array of sixteen doubles was loaded and stored at
// every step at -O2). Returns their sum, so that the compiler keeps the loop.
constexpr int kChains = 16;
double MultiplyAddChains(int steps) {
  using Pair = double __attribute__((vector_size(2 * sizeof(double))));
  Pair x0 = {0, 1}, x1 = {2, 3}, x2 = {4, 5}, x3 = {6, 7};
  Pair x4 = {8, 9}, x5 = {10, 11}, x6 = {12, 13}, x7 = {14, 15};
  const Pair a = {0.999999, 0.999999}, b = {1e-7, 1e-7};
  for (int n = 0; n < steps; ++n) {
    x0 = x0 * a + b;
    x1 = x1 * a + b;
    x2 = x2 * a + b;
    x3 = x3 * a + b;
    x4 = x4 * a + b;
    x5 = x5 * a + b;
    x6 = x6 * a + b;
    x7 = x7 * a + b;
  }
  const Pair sum = ((x0 + x1) + (x2 + x3)) + ((x4 + x5) + (x6 + x7));
  return sum[0] + sum[1];
}

// Units per second of `probe(t, threads)` run on `threads` threads at once.
double MachineRate(int threads, double units_per_thread, double min_seconds,
                   const std::function<void(int, int)>& probe) {
  const double seconds =
      SecondsPerCall([&] { OnThreads(threads, [&](int t) { probe(t, threads); }); }, min_seconds);
  return units_per_thread * threads / seconds;
}

}  // namespace

std::vector<MachineRow> MeasureMachine(const std::string& when, int threads, double min_seconds,
                                       const MachineWork& work) {
  std::vector<MachineRow> rows;
  if (threads < 2) return rows;
  {
    std::vector<double> sums(threads);
    const auto probe = [&](int t, int) { sums[t] = MultiplyAddChains(work.chain_steps); };
    const double per_thread = static_cast<double>(kChains) * work.chain_steps;
    rows.push_back({.probe = "multiply-adds in registers",
                    .when = when,
                    .threads = threads,
                    .unit = "multiply-adds/s",
                    .one_thread = MachineRate(1, per_thread, min_seconds, probe),
                    .these_threads = MachineRate(threads, per_thread, min_seconds, probe)});
    volatile double sink = 0.0;
    for (double sum : sums) sink = sink + sum;
  }
  {
    // Written once before timing (no page faults in the loop); each thread stores its own part,
    // the whole buffer `passes` times a call.
    std::vector<float> buffer(work.buffer_floats, 0.0f);
    const auto probe = [&](int t, int count) {
      const size_t part = buffer.size() / count;
      const auto begin = buffer.begin() + t * part;
      for (int pass = 0; pass < work.passes; ++pass) {
        std::fill(begin, t + 1 == count ? buffer.end() : begin + part, static_cast<float>(pass));
      }
    };
    const double bytes = static_cast<double>(buffer.size() * sizeof(float)) * work.passes;
    rows.push_back({.probe = absl::StrCat("stores to a ", work.buffer_floats * sizeof(float) >> 20,
                                          " MiB buffer"),
                    .when = when,
                    .threads = threads,
                    .unit = "bytes/s",
                    .one_thread = MachineRate(1, bytes, min_seconds, probe),
                    .these_threads = MachineRate(threads, bytes / threads, min_seconds, probe)});
  }
  return rows;
}

MomentImage MakeBenchFrame(ImageGeometry geometry, int m) {
  MomentImage image(geometry, m);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> phase(0.2, 5.5), weight(0.2, 1.0);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::vector<Complex> c(m + 1);
  for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
    const std::vector<double> phases = {phase(rng), phase(rng), phase(rng)};
    const std::vector<double> weights = {weight(rng), weight(rng), weight(rng)};
    DiracMoments(phases, weights, c);
    c[0] += 0.05;
    for (int j = 0; j <= m; ++j) {
      const Complex n = j == 0 ? Complex(0.0) : Complex(noise(rng), noise(rng));
      image.real_plane(j)[p] = static_cast<float>((c[j] + n).real());
      image.imag_plane(j)[p] = static_cast<float>((c[j] + n).imag());
    }
  }
  return image;
}

absl::Status BenchArgs::Validate() const {
  if (!(min_seconds > 0.0 && min_seconds <= 60.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--min-time = ", min_seconds, ": expected 0 < seconds <= 60"));
  }
  if (threads.empty()) return absl::InvalidArgumentError("--threads: expected at least one");
  for (int t : threads) {
    if (t < 1 || t > 256) {
      return absl::InvalidArgumentError(
          absl::StrCat("--threads = ", t, ": expected 1 <= threads <= 256"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<BenchReport> RunBench(const BenchArgs& args, void (*progress)(const BenchRow&)) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  BenchReport report;
  const int most_threads = *std::max_element(args.threads.begin(), args.threads.end());
  report.machine = MeasureMachine("start", most_threads, args.min_seconds);
  std::vector<BenchRow>& rows = report.rows;
  const ImageGeometry pmd{163, 120}, vga{640, 480};
  const double pmd_pixels = static_cast<double>(pmd.pixel_count());

  for (int m : {3, 4, 8}) {
    const MomentImage image = MakeBenchFrame(pmd, m);
    const SolvedImage solved = reference::Solve(image, SolveOptions{});
    const std::vector<double> phases = UniformPhases(256);
    std::vector<float> out(phases.size() * pmd.pixel_count());
    Measure(
        args, "density (256 phases)", m, pmd, "evaluations/s", out.size(),
        [&] { DensitySlices(solved, phases, out); }, &rows, progress);
    SolvedImage reused;
    Measure(
        args, "solve (check, bias, Levinson)", m, pmd, "pixels/s", pmd_pixels,
        [&] { Solve(image, SolveOptions{}, &reused); }, &rows, progress);
    std::vector<float> range(pmd.pixel_count());
    std::vector<uint8_t> flags(pmd.pixel_count());
    Measure(
        args, "range (MESE first peak)", m, pmd, "pixels/s", pmd_pixels,
        [&] { MeseRange(solved, RangeOptions{}, range, flags); }, &rows, progress);
    Measure(
        args, "Pisarenko", m, pmd, "pixels/s", pmd_pixels, [&] { (void)EstimatePisarenko(solved); },
        &rows, progress);
  }
  {
    const MomentImage image = MakeBenchFrame(pmd, 3);
    const SolvedImage solved = reference::Solve(image, SolveOptions{});
    const std::vector<double> phases = UniformPhases(64);
    std::vector<float> out(phases.size() * pmd.pixel_count());
    Measure(
        args, "cumulative (64 phases)", 3, pmd, "evaluations/s", out.size(),
        [&] { CumulativeSlices(solved, phases, out); }, &rows, progress);
  }
  {
    // A depth camera's range: three-frequency phase unwrapping at the Kinect v2's size and
    // harmonics (2, 10, 15 of 8 MHz; "m" is the highest).
    const ImageGeometry kinect{512, 424};
    const MomentImage image = MakeBenchFrame(kinect, 15);
    const UnwrapOptions options{.base_frequency_hz = 8e6, .harmonics = {10, 2, 15}};
    std::vector<float> range, amplitude, confidence;
    std::vector<uint8_t> flags;
    Measure(
        args, "phase unwrapping (Kinect v2)", 15, kinect, "pixels/s",
        static_cast<double>(kinect.pixel_count()),
        [&] { (void)UnwrapImage(image, options, &range, &amplitude, &confidence, &flags); }, &rows,
        progress);
  }
  // The whole per-frame job: moments in; range, amplitude and 64 density slices out.
  for (auto [geometry, m] : {std::pair{pmd, 3}, std::pair{vga, 4}}) {
    const MomentImage image = MakeBenchFrame(geometry, m);
    const std::vector<double> phases = UniformPhases(64);
    const int64_t pixels = geometry.pixel_count();
    std::vector<float> range(pixels), amplitude(pixels), slices(phases.size() * pixels);
    std::vector<uint8_t> flags(pixels);
    SolvedImage solved;  // reused from frame to frame, as a stream would
    Measure(
        args, "pipeline (range, amplitude, 64 slices)", m, geometry, "frames/s", 1.0,
        [&] {
          Solve(image, SolveOptions{}, &solved);
          flags = solved.flags;
          MeseRange(solved, RangeOptions{}, range, flags);
          Amplitude(solved, amplitude);
          DensitySlices(solved, phases, slices);
        },
        &rows, progress);
  }
  for (MachineRow& row : MeasureMachine("end", most_threads, args.min_seconds)) {
    report.machine.push_back(std::move(row));
  }
  return report;
}

std::string FormatBenchTable(const BenchReport& report) {
  const std::vector<BenchRow>& rows = report.rows;
  std::string table = absl::StrFormat("%-40s %3s %9s %7s %14s %14s %8s  %s\n", "kernel", "m",
                                      "size", "threads", "reference", "optimized", "ratio", "unit");
  for (const BenchRow& row : rows) {
    absl::StrAppendFormat(&table, "%-40s %3d %9s %7d %14.4g %14.4g %7.1fx  %s\n", row.kernel,
                          row.order, absl::StrCat(row.width, "x", row.height), row.threads,
                          row.reference, row.optimized, row.ratio(), row.unit);
  }
  if (report.machine.empty()) return table;
  // The machine's rows bound the kernels' ratios from one thread to more.
  absl::StrAppendFormat(&table, "\n%-40s %5s %7s %14s %14s %8s  %s\n", "machine", "when", "threads",
                        "one thread", "threads", "ratio", "unit");
  for (const MachineRow& row : report.machine) {
    absl::StrAppendFormat(&table, "%-40s %5s %7d %14.4g %14.4g %7.2fx  %s\n", row.probe, row.when,
                          row.threads, row.one_thread, row.these_threads, row.ratio(), row.unit);
  }
  return table;
}

std::string FormatBenchJson(const BenchReport& report) {
  const std::vector<BenchRow>& rows = report.rows;
  std::string json = "{\n  \"rows\": [\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const BenchRow& row = rows[i];
    absl::StrAppendFormat(&json,
                          "    {\"kernel\": %s, \"m\": %d, \"width\": %d, \"height\": %d, "
                          "\"threads\": %d, \"unit\": %s, \"reference\": %s, "
                          "\"optimized\": %s, \"ratio\": %s}%s\n",
                          JsonString(row.kernel), row.order, row.width, row.height, row.threads,
                          JsonString(row.unit), JsonNumber(row.reference),
                          JsonNumber(row.optimized), JsonNumber(row.ratio()),
                          i + 1 < rows.size() ? "," : "");
  }
  json += "  ],\n  \"machine\": [\n";
  for (size_t i = 0; i < report.machine.size(); ++i) {
    const MachineRow& row = report.machine[i];
    absl::StrAppendFormat(&json,
                          "    {\"probe\": %s, \"when\": %s, \"threads\": %d, \"unit\": %s, "
                          "\"one_thread\": %s, \"threads_rate\": %s, \"ratio\": %s}%s\n",
                          JsonString(row.probe), JsonString(row.when), row.threads,
                          JsonString(row.unit), JsonNumber(row.one_thread),
                          JsonNumber(row.these_threads), JsonNumber(row.ratio()),
                          i + 1 < report.machine.size() ? "," : "");
  }
  json += "  ]\n}\n";
  return json;
}

}  // namespace transient::tools

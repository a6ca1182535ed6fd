// The experiments of the quality benchmark (thesis §8.5, fig. 8.12 and 8.13): ground truths ×
// noise × methods, each run on many seeded trials, with the metrics of metrics.h. The thesis's
// methods run through the product's reference kernels with the product's default settings, so
// the benchmark measures what `transient reconstruct` and transientd compute.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/eval/ground_truth.h"
#include "tools/eval/metrics.h"
#include "tools/eval/multifrequency.h"
#include "tools/transient/common/command_hooks.h"
#include "transient/reconstruct/cumulative.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient::eval {

enum class TruthKind { kSparse, kContinuous, kKSparse, kCorner };
enum class MethodKind { kSingleFrequency, kGodbaz, kSpumic, kSra, kPisarenko, kMese };

std::string TruthName(TruthKind truth);    // "sparse", "continuous", "k-sparse", "corner"
std::string MethodName(MethodKind method);  // "naive phase", "Godbaz", ..., "MESE"
// The modulation frequencies a method measures at, e.g. "0, 23, 46, 69 MHz".
std::string MethodFrequencies(MethodKind method, int order);

struct ExperimentOptions {
  int trials = 200;  // per (truth, noise, method, m); > 0
  uint64_t seed = 1;
  double snr = 70.0;  // thesis fig. 8.12: noise std = true c_0 / snr, see eval.md
  std::vector<int> orders = {3, 4, 8};  // m of the thesis's methods (and K of the K-sparse truth)
  std::vector<TruthKind> truths = {TruthKind::kSparse, TruthKind::kContinuous,
                                   TruthKind::kKSparse, TruthKind::kCorner};
  std::vector<MethodKind> methods = {MethodKind::kSingleFrequency, MethodKind::kGodbaz,
                                     MethodKind::kSpumic, MethodKind::kSra,
                                     MethodKind::kPisarenko, MethodKind::kMese};
  std::vector<bool> noise = {false, true};
  // The product's defaults (reconstructor.h): bias epsilon 4e-3 raising c_0, threshold 0.1,
  // automatic search bins, base frequency 23 MHz.
  SolveOptions solve;
  RangeOptions range;
  int emd_bins = 2048;  // cells of the EMD integral over one period (21 ps each)
  int corner_width = 163, corner_height = 120;  // the simulator's default camera
  SyntheticTruthOptions synthetic;
  int example_noisy_draws = 6;  // gray curves per panel of the plots
  // The Kinect v2's frequencies (multifrequency.h), with this seed and snr; off: none.
  bool run_multi_frequency = true;
  MultiFrequencyOptions multi_frequency;

  // Names the first violated constraint, e.g. "trials = 0. Violated constraint: trials > 0".
  absl::Status Validate() const;
};

// A reconstruction on the circle of period T = 1/23 MHz: Dirac returns (wrapped mod T when the
// method's own period is longer), a uniform component and/or a MESE cumulative, and the first
// return the method reports.
struct Reconstruction {
  bool valid = false;  // false: the method failed or rejected the input (nothing to compare)
  std::vector<double> dirac_tau_s, dirac_weight;
  double uniform = 0.0;  // light spread evenly over [0, T) (Pisarenko's lambda_min)
  bool has_mese = false;
  MeseCumulative mese;
  double first_tau_s = 0.0;  // NaN when no return passes the threshold
  double period_s = kPeriodS;  // the method's unambiguous range of times of flight

  // Light with time of flight in [0, tau) on the circle, tau in [0, T].
  double Cumulative(double tau_s) const;
};

// One row of the report: a method on one ground truth at one noise level.
struct ResultRow {
  TruthKind truth;
  int k = 0;  // K of the K-sparse truth; 0 otherwise
  MethodKind method;
  int order = 0;  // m of the thesis's methods; 0 for the related methods
  bool noisy = false;
  int trials = 0;
  double found_share = 0.0;      // trials with a first return above the threshold
  double emd_mean_ns = 0.0;      // EMD / true c_0 over trials with a reconstruction
  double emd_median_ns = 0.0;
  ErrorSummary range_error_mm;   // first-return range error over trials with a return
  double within_1cm_share = 0.0;  // trials whose first return is within 1 cm of the truth's
  double time_per_pixel_us = 0.0;
};

// Curves of one example response for a fig. 8.12-style plot: per method, the cumulative
// distribution without noise and for a few noise draws, normalized by the true c_0.
struct CurveSet {
  MethodKind method;
  int order = 0;
  std::vector<double> noise_free;            // at ExampleCurves::tau_ns
  std::vector<std::vector<double>> noisy;
};
struct ExampleCurves {
  TruthKind truth;
  std::vector<double> tau_ns;
  std::vector<double> truth_curve;
  std::vector<CurveSet> methods;
};

// The scanline of the corner for a fig. 8.13-style top view: x and depth (z) in metres.
struct TopView {
  std::vector<double> truth_x_m, truth_z_m;
  struct Points {
    MethodKind method;
    int order = 0;
    std::vector<double> noise_free_x_m, noise_free_z_m, noisy_x_m, noisy_z_m;
  };
  std::vector<Points> methods;
};

struct ExperimentResult {
  std::vector<ResultRow> rows;
  std::vector<ExampleCurves> examples;  // sparse and continuous (trial 0)
  TopView top_view;
  // max over trials of the light outside [0, T) / c_0, per truth (what wrapping moved)
  std::vector<std::pair<TruthKind, double>> light_outside;
  std::vector<MultiFrequencyRow> multi_frequency;
  double seconds = 0.0;
};

// A command's progress and cancel flag (Cancelled when it becomes true), and a line per stage.
struct ExperimentHooks : tools::CommandHooks {
  std::function<void(const std::string& line)> on_stage = nullptr;
};

// Runs every (truth, noise, method, m) configuration. InvalidArgument for bad options;
// Internal when the corner scene cannot be rendered; Cancelled when asked to stop.
absl::StatusOr<ExperimentResult> RunExperiments(const ExperimentOptions& options,
                                                const ExperimentHooks& hooks = {});

// Reconstructions of `responses` by one method (exposed for tests): measurements at the
// method's frequencies, Gaussian noise with std = c_0 / snr on the real and imaginary part of
// each (the real part only at 0 Hz) when `noisy`, seeded by `noise_key` and the trial index.
// `seconds` receives the time spent reconstructing (steady clock, all trials).
std::vector<Reconstruction> Reconstruct(MethodKind method, int order,
                                        const std::vector<ImpulseResponse>& responses,
                                        bool noisy, const ExperimentOptions& options,
                                        uint64_t noise_key, double* seconds);

}  // namespace transient::eval

// `transient eval` (eval_command.h): the benchmark's report in Markdown, JSON and SVG.
#include "tools/eval/eval_command.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <system_error>
#include <tuple>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "tools/eval/svg_plot.h"
#include "tools/transient/common/json_text.h"
#include "transient/formats/atomic_output.h"

namespace transient::eval {
namespace {

constexpr char kMarkdownFile[] = "eval.md";
constexpr char kJsonFile[] = "eval.json";

// Colours of thesis fig. 8.12: ground truth dotted blue, noise-free red, noisy gray.
constexpr char kTruthColor[] = "#1f4fd0", kCleanColor[] = "#d01f1f", kNoisyColor[] = "#8c8c8c";

std::string MethodLabel(MethodKind method, int order) {
  return order > 0 ? absl::StrCat(MethodName(method), " (m = ", order, ")") : MethodName(method);
}

std::string TruthTitle(TruthKind truth) {
  switch (truth) {
    case TruthKind::kSparse: return "three sparse returns (thesis fig. 8.12a)";
    case TruthKind::kContinuous: return "three continuous returns (EMG, thesis fig. 8.12b)";
    case TruthKind::kKSparse: return "random K-sparse responses, K = m";
    case TruthKind::kCorner: return "diffuse corner, range (simulator scene `corner`, thesis fig. 8.13)";
  }
  return "";
}

std::string TruthDescription(TruthKind truth, const ExperimentOptions& o) {
  const SyntheticTruthOptions& s = o.synthetic;
  switch (truth) {
    case TruthKind::kSparse:
      return absl::StrFormat(
          "Three Dirac returns per trial, delays uniform in [%g, %g] ns at least %g ns apart, "
          "weights uniform in [%g, %g].",
          s.first_delay_s * 1e9, s.last_delay_s * 1e9, s.min_separation_s * 1e9, s.min_weight,
          s.max_weight);
    case TruthKind::kContinuous:
      return absl::StrFormat(
          "Three exponentially modified Gaussians per trial (onset + N(0, sigma^2) + Exp with "
          "mean 1/lambda): onsets uniform in [%g, %g] ns at least %g ns apart, sigma in [%g, %g] "
          "ns, 1/lambda in [%g, %g] ns, weights in [%g, %g].",
          s.first_onset_s * 1e9, s.last_onset_s * 1e9, s.min_separation_s * 1e9,
          s.min_sigma_s * 1e9, s.max_sigma_s * 1e9, s.min_tail_s * 1e9, s.max_tail_s * 1e9,
          s.min_weight, s.max_weight);
    case TruthKind::kKSparse:
      return absl::StrFormat(
          "K Dirac returns per trial anywhere in [%g, T - %g] ns, at least %g ns apart, weights "
          "in [%g, %g]; the thesis's methods run at m = K, where Pisarenko is exact without "
          "noise (thesis §8.4.1).",
          s.ksparse_margin_s * 1e9, s.ksparse_margin_s * 1e9, s.ksparse_min_separation_s * 1e9,
          s.min_weight, s.max_weight);
    case TruthKind::kCorner:
      return absl::StrFormat(
          "Pixels drawn uniformly from the lit pixels of the simulator's `corner` scene "
          "(%dx%d camera): a Dirac (direct path) and an EMG (one diffuse bounce off the other "
          "wall) per pixel. Only the impulse responses are taken from the simulator; the "
          "measurements and noise are this benchmark's (no sensor model).",
          o.corner_width, o.corner_height);
  }
  return "";
}

// `digits` after the decimal point; a dash for no value.
std::string Number(double value, int digits) {
  return std::isfinite(value) ? absl::StrFormat("%.*f", digits, value) : std::string("–");
}

using ::transient::tools::JsonNumber;

std::vector<ResultRow> SortedRows(const ExperimentResult& result, TruthKind truth) {
  std::vector<ResultRow> rows;
  for (const ResultRow& row : result.rows) {
    if (row.truth == truth) rows.push_back(row);
  }
  std::stable_sort(rows.begin(), rows.end(), [](const ResultRow& a, const ResultRow& b) {
    return std::make_tuple(a.k, static_cast<int>(a.method), a.noisy, a.order) <
           std::make_tuple(b.k, static_cast<int>(b.method), b.noisy, b.order);
  });
  return rows;
}

std::string Definitions(const ExperimentOptions& o) {
  return absl::StrFormat(
      "## Definitions\n\n"
      "- **Period.** T = 1/23 MHz = %.2f ns. Times of flight τ are round trips; range = c·τ/2.\n"
      "- **Measurements.** At frequency f, m(f) = Σ_l a_l E[exp(i·2π·f·t_l)] over the returns "
      "(closed form for Diracs and EMGs). MESE uses c_j = m(j·23 MHz), j = 0..m (c_0 "
      "measured); Pisarenko uses j = 1..m and estimates c_0 from λ_min (thesis fig. 8.12: the "
      "0 Hz measurement is for MESE only). Both run through the product's reference kernels "
      "(reconstructor.h; moments stored as float as in a MomentImage) with its defaults: "
      "biasing raises c_0 until λ_min ≥ %g·c_0, threshold %g, %s search bins. Related "
      "methods (tools/eval/baselines.h) use their own frequencies (column `frequencies`): "
      "Godbaz et al. 2012 two Diracs in closed form, SPUMIC (Kirmani et al. 2013) two returns, "
      "SRA (Freedman et al. 2014) LP with ε = 0.05 on a 512-bin grid.\n"
      "- **Noise (SNR %g:1).** Every measured complex value gets independent Gaussian noise on "
      "its real and on its imaginary part with standard deviation (true c_0)/%g (the 0 Hz "
      "value: real part only), independently per frequency, trial and method. `none` is "
      "noise-free.\n"
      "- **EMD (ns).** Earth mover's distance between reconstructed and true distributions of "
      "τ on the circle of period T: min over α of ∫_0^T |F_rec(τ) − F_true(τ) − α| dτ, "
      "divided by the true c_0, where F(τ) is the light with τ mod T in [0, τ). Returns of "
      "methods with a longer period (11 MHz: 90.9 ns) are wrapped mod T, and so is the truth "
      "(the light it has outside [0, T) is listed per table). Pisarenko's reconstruction "
      "includes its uniform component λ_min (after biasing ε·c_0: an exact fit of the returns "
      "still scores ε/(1−ε)·T/4 = %.3f ns) and MESE its biased c_0. Midpoint rule on %d cells "
      "cut at every Dirac (exact for step functions). Mean and median over the trials with a "
      "reconstruction.\n"
      "- **Range error (mm).** First return of the method (MESE: first density peak; "
      "Pisarenko and the related methods: earliest return; each at least %g × the strongest, "
      "ordered with the product's wrap guard) minus the true first return (earliest return "
      "with at least %g × the largest amplitude: the Dirac's delay or the EMG's mode), as "
      "range c·τ/2, wrapped to the nearest period of the method's own lowest frequency (6.52 m "
      "at 23 MHz, 13.6 m at 11 MHz). Signed mean, RMSE and 95th percentile of |error| over the "
      "trials with a return. **within 1 cm**: share of all trials whose first return is within "
      "10 mm of the truth's.\n"
      "- **found.** Share of trials with a reconstruction and a first return.\n"
      "- **µs/pixel.** Steady-clock time of reconstruction and first return over all trials "
      "of a row divided by the trials (metrics excluded), one thread. The thesis's methods run "
      "the scalar reference kernels here; the optimized kernels of the daemon are faster "
      "(`transient bench`).\n",
      kPeriodS * 1e9, o.solve.bias_epsilon, o.range.threshold,
      o.range.search_bins > 0 ? absl::StrCat(o.range.search_bins) : "16·(m+1)", o.snr, o.snr,
      o.solve.bias_epsilon / (1.0 - o.solve.bias_epsilon) * kPeriodS * 1e9 / 4.0, o.emd_bins,
      o.range.threshold, o.range.threshold);
}

std::vector<PlotPanel> ExamplePanels(const ExampleCurves& example) {
  std::vector<PlotPanel> panels;
  for (const CurveSet& set : example.methods) {
    PlotPanel panel;
    panel.title = MethodLabel(set.method, set.order);
    panel.x_label = "time of flight τ (ns)";
    panel.y_label = "cumulative light / c₀";
    panel.x_low = 0.0, panel.x_high = kPeriodS * 1e9;
    panel.y_low = 0.0, panel.y_high = 1.15;
    for (size_t d = 0; d < set.noisy.size(); ++d) {
      panel.series.push_back({SeriesStyle::kLine, example.tau_ns, set.noisy[d], kNoisyColor, 1.0,
                              "", 0.7, d == 0 ? "SNR 70:1" : ""});
    }
    panel.series.push_back({SeriesStyle::kLine, example.tau_ns, set.noise_free, kCleanColor, 1.6,
                            "", 1.0, "no noise"});
    panel.series.push_back({SeriesStyle::kLine, example.tau_ns, example.truth_curve, kTruthColor,
                            1.6, "2,3", 1.0, "ground truth"});
    panels.push_back(std::move(panel));
  }
  return panels;
}

std::vector<PlotPanel> TopViewPanels(const TopView& view) {
  double x_low = 1e9, x_high = -1e9, z_low = 1e9, z_high = -1e9;
  for (size_t i = 0; i < view.truth_x_m.size(); ++i) {
    if (!std::isfinite(view.truth_x_m[i]) || !std::isfinite(view.truth_z_m[i])) continue;
    x_low = std::min(x_low, view.truth_x_m[i]), x_high = std::max(x_high, view.truth_x_m[i]);
    z_low = std::min(z_low, view.truth_z_m[i]), z_high = std::max(z_high, view.truth_z_m[i]);
  }
  std::vector<PlotPanel> panels;
  for (const TopView::Points& points : view.methods) {
    PlotPanel panel;
    panel.title = MethodLabel(points.method, points.order);
    panel.x_label = "x (m)";
    panel.y_label = "depth z (m)";
    // Fixed to the truth with a margin, so that outliers do not shrink the corner.
    panel.x_low = x_low - 0.15, panel.x_high = x_high + 0.15;
    panel.y_low = z_low - 0.3, panel.y_high = z_high + 0.6;
    panel.equal_scale = true;
    panel.series.push_back({SeriesStyle::kPoints, points.noisy_x_m, points.noisy_z_m,
                            kNoisyColor, 1.6, "", 0.8, "SNR 70:1"});
    panel.series.push_back({SeriesStyle::kPoints, points.noise_free_x_m, points.noise_free_z_m,
                            kCleanColor, 1.6, "", 1.0, "no noise"});
    panel.series.push_back({SeriesStyle::kLine, view.truth_x_m, view.truth_z_m, "#000000", 1.2,
                            "", 1.0, "ground truth"});
    panels.push_back(std::move(panel));
  }
  return panels;
}

absl::Status PrepareOutput(const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error || !std::filesystem::is_directory(dir)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--out ", dir, ": cannot create the output directory",
        error ? absl::StrCat(": ", error.message()) : std::string(": not a directory")));
  }
  // Fail now, not after minutes of computing, when the directory is not writable.
  const std::filesystem::path probe = std::filesystem::path(dir) / ".transient-eval-probe";
  if (absl::Status status = WriteTextFile(probe.string(), ""); !status.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--out ", dir, ": the output directory is not writable"));
  }
  std::filesystem::remove(probe, error);
  return absl::OkStatus();
}

}  // namespace

absl::Status EvalArgs::Validate() const {
  if (trials <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--trials = ", trials, ". Violated constraint: trials > 0"));
  }
  if (output_dir.empty()) {
    return absl::InvalidArgumentError("--out is empty. Violated constraint: a directory path");
  }
  return absl::OkStatus();
}

std::string FormatMarkdown(const ExperimentResult& result, const ExperimentOptions& options) {
  std::string md = absl::StrFormat(
      "# transient eval: quality benchmark\n\n"
      "Thesis §8.5, fig. 8.12 and 8.13, reproduced on synthetic data: %d trials per row, seed "
      "%d, %.1f s. Plots: `cdf_sparse.svg`, `cdf_continuous.svg` (one response, its "
      "cumulative reconstructed without noise in red and for %d noise draws in gray, truth "
      "dotted blue) and `corner_top_view.svg` (the middle scanline of the corner seen from "
      "above, ground truth black).\n\n",
      options.trials, options.seed, result.seconds, options.example_noisy_draws);
  absl::StrAppend(&md, Definitions(options));
  for (TruthKind truth : options.truths) {
    const std::vector<ResultRow> rows = SortedRows(result, truth);
    if (rows.empty()) continue;
    double outside = 0.0;
    for (const auto& [kind, light] : result.light_outside) {
      if (kind == truth) outside = light;
    }
    absl::StrAppend(&md, "\n## ", TruthTitle(truth), "\n\n", TruthDescription(truth, options),
                    absl::StrFormat(" Light outside [0, T): at most %.2g of c_0 per trial.\n\n",
                                    outside));
    const bool k_column = truth == TruthKind::kKSparse;
    absl::StrAppend(&md, k_column ? "| K " : "",
                    "| method | noise | m | frequencies | found | EMD mean (ns) | EMD median (ns) "
                    "| range mean (mm) | range RMSE (mm) | \\|range\\| p95 (mm) | within 1 cm "
                    "| µs/pixel |\n",
                    k_column ? "|---" : "",
                    "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const ResultRow& row : rows) {
      absl::StrAppend(
          &md, k_column ? absl::StrCat("| ", row.k, " ") : "", "| ", MethodName(row.method),
          " | ", row.noisy ? absl::StrFormat("SNR %g:1", options.snr) : "none", " | ",
          row.order > 0 ? absl::StrCat(row.order) : "–", " | ",
          MethodFrequencies(row.method, row.order), " | ",
          absl::StrFormat("%.0f%%", 100.0 * row.found_share), " | ",
          Number(row.emd_mean_ns, 3), " | ", Number(row.emd_median_ns, 3), " | ",
          Number(row.range_error_mm.mean, 2), " | ", Number(row.range_error_mm.rmse, 2),
          " | ", Number(row.range_error_mm.p95_abs, 2), " | ",
          absl::StrFormat("%.1f%%", 100.0 * row.within_1cm_share), " | ",
          Number(row.time_per_pixel_us, 2), " |\n");
    }
  }
  if (!result.multi_frequency.empty()) {
    absl::StrAppend(
        &md,
        "\n## The Kinect v2's frequencies: 16, 80, 120 MHz\n\n"
        "Harmonics 2, 10, 15 of 8 MHz (unambiguous range 18.74 m), measured on the simulator's "
        "corner and mirrors scenes (",
        options.multi_frequency.width, "x", options.multi_frequency.height, ", every ",
        options.multi_frequency.pixel_stride,
        "th lit pixel), with the noise above. Methods: libfreenect2's per-pixel unwrapping "
        "(its CPU processor's stage 2 without the spatial filters and amplitude thresholds), "
        "transientd's maximum-likelihood unwrapping (phase_unwrapping.h, the product's), and a "
        "two-return fit across the three frequencies. *found*: pixels with a range; *off > "
        "0.5 m*: ranges further than that from the true first return (a wrong unwrapping "
        "candidate, or another return taken for the first: a mirror path), left out of the "
        "error columns.\n\n"
        "| scene | method | noise | found | off > 0.5 m | range mean (mm) | range RMSE (mm) "
        "| \\|range\\| median (mm) | \\|range\\| p95 (mm) | µs/pixel |\n"
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const MultiFrequencyRow& row : result.multi_frequency) {
      absl::StrAppend(&md, "| ", row.scene, " | ", UnwrapMethodName(row.method), " | ",
                      row.noisy ? absl::StrFormat("SNR %g:1", options.snr) : "none", " | ",
                      absl::StrFormat("%.1f%%", 100.0 * row.found_share), " | ",
                      absl::StrFormat("%.2f%%", 100.0 * row.wrap_errors), " | ",
                      Number(row.range_error_mm.mean, 2), " | ", Number(row.range_error_mm.rmse, 2),
                      " | ", Number(row.median_abs_mm, 2), " | ",
                      Number(row.range_error_mm.p95_abs, 2), " | ",
                      Number(row.time_per_pixel_us, 2), " |\n");
    }
  }
  return md;
}

std::string FormatJson(const ExperimentResult& result, const ExperimentOptions& options) {
  std::string json = absl::StrFormat(
      "{\n  \"format\": \"transient-eval 1\",\n  \"trials\": %d,\n  \"seed\": %d,\n"
      "  \"snr\": %s,\n  \"period_ns\": %s,\n  \"bias_epsilon\": %s,\n  \"threshold\": %s,\n"
      "  \"seconds\": %s,\n  \"noise\": \"independent Gaussian on the real and imaginary part "
      "of every measured value, std = true c_0 / snr (0 Hz: real part only)\",\n"
      "  \"light_outside_period\": {",
      options.trials, options.seed, JsonNumber(options.snr), JsonNumber(kPeriodS * 1e9),
      JsonNumber(options.solve.bias_epsilon), JsonNumber(options.range.threshold),
      JsonNumber(result.seconds));
  for (size_t i = 0; i < result.light_outside.size(); ++i) {
    absl::StrAppend(&json, i > 0 ? ", " : "", "\"", TruthName(result.light_outside[i].first),
                    "\": ", JsonNumber(result.light_outside[i].second));
  }
  absl::StrAppend(&json, "},\n  \"rows\": [\n");
  for (size_t i = 0; i < result.rows.size(); ++i) {
    const ResultRow& r = result.rows[i];
    absl::StrAppendFormat(
        &json,
        "    {\"truth\": \"%s\", \"k\": %d, \"method\": \"%s\", \"order\": %d, \"noise\": %s, "
        "\"frequencies\": \"%s\", \"trials\": %d, \"found_share\": %s, \"emd_mean_ns\": %s, "
        "\"emd_median_ns\": %s, \"range_mean_mm\": %s, \"range_rmse_mm\": %s, "
        "\"range_p95_abs_mm\": %s, \"range_count\": %d, \"within_1cm_share\": %s, "
        "\"time_per_pixel_us\": %s}%s\n",
        TruthName(r.truth), r.k, MethodName(r.method), r.order, r.noisy ? "true" : "false",
        MethodFrequencies(r.method, r.order), r.trials, JsonNumber(r.found_share),
        JsonNumber(r.emd_mean_ns), JsonNumber(r.emd_median_ns), JsonNumber(r.range_error_mm.mean),
        JsonNumber(r.range_error_mm.rmse), JsonNumber(r.range_error_mm.p95_abs),
        r.range_error_mm.count, JsonNumber(r.within_1cm_share), JsonNumber(r.time_per_pixel_us),
        i + 1 < result.rows.size() ? "," : "");
  }
  absl::StrAppend(&json, "  ],\n  \"kinect2_frequencies\": [\n");
  for (size_t i = 0; i < result.multi_frequency.size(); ++i) {
    const MultiFrequencyRow& r = result.multi_frequency[i];
    absl::StrAppendFormat(
        &json,
        "    {\"scene\": \"%s\", \"method\": \"%s\", \"noise\": %s, \"pixels\": %d, "
        "\"found_share\": %s, \"wrong_unwrap_share\": %s, \"range_mean_mm\": %s, "
        "\"range_rmse_mm\": %s, \"range_median_abs_mm\": %s, \"range_p95_abs_mm\": %s, "
        "\"time_per_pixel_us\": %s}%s\n",
        r.scene, UnwrapMethodName(r.method), r.noisy ? "true" : "false", r.pixels,
        JsonNumber(r.found_share), JsonNumber(r.wrap_errors), JsonNumber(r.range_error_mm.mean),
        JsonNumber(r.range_error_mm.rmse), JsonNumber(r.median_abs_mm),
        JsonNumber(r.range_error_mm.p95_abs), JsonNumber(r.time_per_pixel_us),
        i + 1 < result.multi_frequency.size() ? "," : "");
  }
  absl::StrAppend(&json, "  ]\n}\n");
  return json;
}

absl::StatusOr<EvalSummary> RunEval(const EvalArgs& args, const ExperimentHooks& hooks) {
  return RunEval(args, ExperimentOptions(), hooks);
}

absl::StatusOr<EvalSummary> RunEval(const EvalArgs& args, const ExperimentOptions& defaults,
                                    const ExperimentHooks& hooks) {
  if (absl::Status status = args.Validate(); !status.ok()) return status;
  ExperimentOptions options = defaults;
  options.trials = args.trials;
  options.seed = args.seed;
  if (absl::Status status = PrepareOutput(args.output_dir); !status.ok()) return status;
  absl::StatusOr<ExperimentResult> result = RunExperiments(options, hooks);
  if (!result.ok()) return result.status();

  EvalSummary summary;
  summary.output_dir = args.output_dir;
  summary.rows = static_cast<int>(result->rows.size() + result->multi_frequency.size());
  summary.seconds = result->seconds;
  const std::filesystem::path dir(args.output_dir);
  auto write = [&](const std::string& name, const std::string& content) -> absl::Status {
    if (absl::Status status = WriteTextFile((dir / name).string(), content); !status.ok()) {
      return status;
    }
    summary.files.push_back(name);
    return absl::OkStatus();
  };
  if (absl::Status s = write(kMarkdownFile, FormatMarkdown(*result, options)); !s.ok()) return s;
  if (absl::Status s = write(kJsonFile, FormatJson(*result, options)); !s.ok()) return s;
  for (const ExampleCurves& example : result->examples) {
    const std::string name = absl::StrCat("cdf_", TruthName(example.truth), ".svg");
    const std::string title = absl::StrCat(
        "Cumulative distribution of time of flight: ", TruthTitle(example.truth));
    if (absl::Status s = write(name, RenderSvg(ExamplePanels(example), 3, title)); !s.ok()) {
      return s;
    }
  }
  if (!result->top_view.methods.empty()) {
    if (absl::Status s = write("corner_top_view.svg",
                               RenderSvg(TopViewPanels(result->top_view), 4,
                                         "Diffuse corner, top view of the middle scanline "
                                         "(first-return range, f = 23 MHz)",
                                         320.0, 340.0));
        !s.ok()) {
      return s;
    }
  }
  return summary;
}

std::string FormatEvalSummary(const EvalSummary& summary) {
  return absl::StrFormat("wrote %d files to %s (%d rows, %.1f s): %s", summary.files.size(),
                         summary.output_dir, summary.rows, summary.seconds,
                         absl::StrJoin(summary.files, ", "));
}

}  // namespace transient::eval

// The benchmark's experiments (experiment.h).
#include "tools/eval/experiment.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "tools/eval/baselines.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/percentile.h"
#include "transient/reconstruct/range.h"

namespace transient::eval {
namespace {


// Streams of the benchmark's randomness; each draw is keyed by (seed, stream, ..., trial), so a
// configuration's numbers do not depend on which other configurations run.
constexpr uint64_t kTruthStream = 1, kNoiseStream = 2, kCornerPixelStream = 3,
                   kExampleStream = 4, kTopViewStream = 5;

// Related methods' frequencies as in thesis fig. 8.12: Godbaz et al. at 11, 22, 33, 44 MHz,
// SPUMIC at 11, ..., 66 MHz, SRA at 23, 46, 69 MHz.
constexpr double kLowBaseHz = 11e6;
constexpr int kGodbazMeasurements = 4, kSpumicMeasurements = 6, kSpumicReturns = 2;
constexpr int kSraMeasurements = 3;
constexpr double kSraEpsilon = 0.05;

std::vector<double> Frequencies(MethodKind method, int order) {
  std::vector<double> f;
  switch (method) {
    case MethodKind::kSingleFrequency:
      return {kBaseFrequencyHz};
    case MethodKind::kGodbaz:
      for (int k = 1; k <= kGodbazMeasurements; ++k) f.push_back(k * kLowBaseHz);
      return f;
    case MethodKind::kSpumic:
      for (int k = 1; k <= kSpumicMeasurements; ++k) f.push_back(k * kLowBaseHz);
      return f;
    case MethodKind::kSra:
      for (int k = 1; k <= kSraMeasurements; ++k) f.push_back(k * kBaseFrequencyHz);
      return f;
    case MethodKind::kPisarenko:  // c_0 is estimated (thesis fig. 8.12: no 0 Hz measurement)
      for (int j = 1; j <= order; ++j) f.push_back(j * kBaseFrequencyHz);
      return f;
    case MethodKind::kMese:
      for (int j = 0; j <= order; ++j) f.push_back(j * kBaseFrequencyHz);
      return f;
  }
  return f;
}

double LowestPeriod(MethodKind method) {
  return method == MethodKind::kGodbaz || method == MethodKind::kSpumic ? 1.0 / kLowBaseHz
                                                                         : kPeriodS;
}

Complex Noise(double sigma, bool real_only, RandomStream& random) {
  const double re = sigma * random.Normal();
  const double im = sigma * random.Normal();  // drawn anyway: streams stay aligned
  return {re, real_only ? 0.0 : im};
}

// Measurements of `response` at `frequencies`, with the benchmark's noise when `noisy`.
void Measure(const ImpulseResponse& response, const std::vector<double>& frequencies, bool noisy,
             double snr, RandomStream& random, std::vector<Complex>* out) {
  out->resize(frequencies.size());
  const double sigma = response.TotalLight() / snr;
  for (size_t n = 0; n < frequencies.size(); ++n) {
    (*out)[n] = response.Measure(frequencies[n]);
    if (noisy) (*out)[n] += Noise(sigma, frequencies[n] == 0.0, random);
  }
}

// A sparse reconstruction of a related method on the circle of period T, with its first return
// chosen as the product chooses Pisarenko's (thesis §8.4.3): the earliest return, in the order
// of OrderingPhase at the method's lowest frequency, whose weight is >= threshold * largest.
Reconstruction FromSparse(const SparseReturns& returns, double threshold, double lowest_hz) {
  Reconstruction rec;
  rec.valid = true;
  rec.period_s = 1.0 / lowest_hz;
  double largest = 0.0;
  for (double w : returns.weight) largest = std::max(largest, w);
  double first_phase = kNaN;
  for (size_t l = 0; l < returns.time_of_flight_s.size(); ++l) {
    const double tau = returns.time_of_flight_s[l];
    rec.dirac_tau_s.push_back(tau - std::floor(tau / kPeriodS) * kPeriodS);
    rec.dirac_weight.push_back(returns.weight[l]);
    if (returns.weight[l] > 0.0 && returns.weight[l] >= threshold * largest) {
      const double phase = OrderingPhase(kTwoPi * lowest_hz * tau);
      if (std::isnan(first_phase) || phase < first_phase) first_phase = phase;
    }
  }
  rec.first_tau_s = first_phase / (kTwoPi * lowest_hz);
  return rec;
}

template <typename Clock>
double SecondsSince(typename Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

uint64_t ConfigKey(TruthKind truth, int k, MethodKind method, int order, bool noisy) {
  return (uint64_t(truth) << 48) | (uint64_t(k) << 40) | (uint64_t(method) << 32) |
         (uint64_t(order) << 8) | uint64_t(noisy);
}

std::vector<ImpulseResponse> SyntheticResponses(TruthKind truth, int k,
                                                const ExperimentOptions& options, int count,
                                                uint64_t stream) {
  std::vector<ImpulseResponse> responses;
  for (int t = 0; t < count; ++t) {
    RandomStream random({options.seed, stream, uint64_t(truth), uint64_t(k), uint64_t(t)});
    switch (truth) {
      case TruthKind::kSparse:
        responses.push_back(RandomSparse(3, options.synthetic, random));
        break;
      case TruthKind::kContinuous:
        responses.push_back(RandomContinuous(3, options.synthetic, random));
        break;
      case TruthKind::kKSparse:
        responses.push_back(RandomKSparse(k, options.synthetic, random));
        break;
      case TruthKind::kCorner:
        break;  // not synthetic
    }
  }
  return responses;
}

}  // namespace

std::string TruthName(TruthKind truth) {
  switch (truth) {
    case TruthKind::kSparse: return "sparse";
    case TruthKind::kContinuous: return "continuous";
    case TruthKind::kKSparse: return "k-sparse";
    case TruthKind::kCorner: return "corner";
  }
  return "?";
}

std::string MethodName(MethodKind method) {
  switch (method) {
    case MethodKind::kSingleFrequency: return "naive phase";
    case MethodKind::kGodbaz: return "Godbaz 2-Dirac";
    case MethodKind::kSpumic: return "SPUMIC";
    case MethodKind::kSra: return "SRA";
    case MethodKind::kPisarenko: return "Pisarenko";
    case MethodKind::kMese: return "MESE";
  }
  return "?";
}

std::string MethodFrequencies(MethodKind method, int order) {
  std::vector<std::string> mhz;
  for (double f : Frequencies(method, order)) mhz.push_back(absl::StrCat(std::lround(f * 1e-6)));
  return absl::StrCat(absl::StrJoin(mhz, ", "), " MHz");
}

absl::Status ExperimentOptions::Validate() const {
  if (trials <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("trials = ", trials, ". Violated constraint: trials > 0"));
  }
  if (!(snr > 0.0) || !std::isfinite(snr)) {
    return absl::InvalidArgumentError(
        absl::StrCat("snr = ", snr, ". Violated constraint: finite and > 0"));
  }
  for (int m : orders) {
    if (m < 1 || m > kMaxOrder) {
      return absl::InvalidArgumentError(
          absl::StrCat("order = ", m, ". Violated constraint: 1 <= order <= ", kMaxOrder));
    }
  }
  if (emd_bins < 16) {
    return absl::InvalidArgumentError(
        absl::StrCat("emd_bins = ", emd_bins, ". Violated constraint: emd_bins >= 16"));
  }
  if (example_noisy_draws < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "example_noisy_draws = ", example_noisy_draws, ". Violated constraint: >= 0"));
  }
  if (absl::Status s = solve.Validate(); !s.ok()) return s;
  return range.Validate();
}

double Reconstruction::Cumulative(double tau_s) const {
  double sum = uniform * tau_s / kPeriodS;
  for (size_t l = 0; l < dirac_tau_s.size(); ++l) {
    if (dirac_tau_s[l] < tau_s) sum += dirac_weight[l];
  }
  if (has_mese) sum += mese(std::clamp(kTwoPi * tau_s / kPeriodS, 0.0, kTwoPi));
  return sum;
}

std::vector<Reconstruction> Reconstruct(MethodKind method, int order,
                                        const std::vector<ImpulseResponse>& responses,
                                        bool noisy, const ExperimentOptions& options,
                                        uint64_t noise_key, double* seconds) {
  using Clock = std::chrono::steady_clock;
  const int count = static_cast<int>(responses.size());
  std::vector<Reconstruction> out(count);
  const std::vector<double> frequencies = Frequencies(method, order);
  std::vector<std::vector<Complex>> measured(count);
  for (int p = 0; p < count; ++p) {
    RandomStream random({options.seed, kNoiseStream, noise_key, uint64_t(p)});
    Measure(responses[p], frequencies, noisy, options.snr, random, &measured[p]);
  }
  if (count == 0) {
    *seconds = 0.0;
    return out;
  }

  if (method == MethodKind::kMese || method == MethodKind::kPisarenko) {
    // One image of `count` pixels: the product's image-level API, reference (scalar,
    // single-threaded) kernels, so that the time per pixel compares with the related methods.
    MomentImage image(ImageGeometry{count, 1}, order);
    const bool mese = method == MethodKind::kMese;
    for (int p = 0; p < count; ++p) {
      for (int j = 0; j <= order; ++j) {
        // Pisarenko's c_0 is not measured: plane 0 is ignored (ZerothMoment::kEstimate).
        const Complex c = mese ? measured[p][j] : (j == 0 ? Complex(0.0) : measured[p][j - 1]);
        image.real_plane(j)[p] = static_cast<float>(c.real());
        image.imag_plane(j)[p] = static_cast<float>(j == 0 ? 0.0 : c.imag());
      }
    }
    SolveOptions solve = options.solve;
    if (!mese) solve.zeroth = ZerothMoment::kEstimate;
    SolvedImage solved;
    PisarenkoImage pisarenko;
    std::vector<float> range_m(count);
    const Clock::time_point start = Clock::now();
    reference::Solve(image, solve, &solved);
    std::vector<uint8_t> flags = solved.flags;
    if (mese) {
      reference::MeseRange(solved, options.range, range_m, flags);
    } else {
      pisarenko = reference::EstimatePisarenko(solved);
      reference::PisarenkoRange(pisarenko, options.range, range_m, flags);
    }
    *seconds = SecondsSince<Clock>(start);

    std::array<Complex, kMaxMoments> q_storage;
    const std::span<Complex> q(q_storage.data(), order + 1);
    for (int p = 0; p < count; ++p) {
      Reconstruction& rec = out[p];
      rec.first_tau_s = std::isnan(range_m[p]) ? kNaN : 2.0 * range_m[p] / kSpeedOfLight;
      if (!solved.valid(p)) continue;
      if (mese) {
        solved.coefficients(p, q);
        rec.valid = rec.mese.Init(q);
        rec.has_mese = rec.valid;
        continue;
      }
      if (std::isnan(pisarenko.uniform[p])) continue;
      rec.valid = true;
      rec.uniform = pisarenko.uniform[p];
      for (int l = 0; l < order; ++l) {
        const float w = pisarenko.weight[l * count + p];
        if (std::isnan(w)) break;
        rec.dirac_tau_s.push_back(pisarenko.phase[l * count + p] / kTwoPi * kPeriodS);
        rec.dirac_weight.push_back(w);
      }
    }
    return out;
  }

  const double threshold = options.range.threshold;
  const double lowest_hz = 1.0 / LowestPeriod(method);
  const Clock::time_point start = Clock::now();
  for (int p = 0; p < count; ++p) {
    absl::StatusOr<SparseReturns> returns;
    switch (method) {
      case MethodKind::kSingleFrequency:
        returns = SingleFrequencyPhase(measured[p][0], kBaseFrequencyHz);
        break;
      case MethodKind::kGodbaz:
        returns = GodbazTwoDirac(measured[p], kLowBaseHz);
        break;
      case MethodKind::kSpumic:
        returns = Spumic(measured[p], kLowBaseHz, kSpumicReturns);
        break;
      case MethodKind::kSra:
        returns = Sra(frequencies, measured[p], kSraEpsilon);
        break;
      default:
        break;
    }
    if (returns.ok()) {
      out[p] = FromSparse(*returns, threshold, lowest_hz);
    } else {
      out[p].first_tau_s = kNaN;
    }
  }
  *seconds = SecondsSince<Clock>(start);
  return out;
}

namespace {

ResultRow Evaluate(TruthKind truth, int k, MethodKind method, int order, bool noisy,
                   const std::vector<ImpulseResponse>& responses,
                   const std::vector<Reconstruction>& recs, double seconds,
                   const ExperimentOptions& options) {
  ResultRow row;
  row.truth = truth;
  row.k = k;
  row.method = method;
  row.order = order;
  row.noisy = noisy;
  row.trials = static_cast<int>(responses.size());
  std::vector<double> emd_ns, errors_mm;
  int found = 0;
  for (size_t p = 0; p < responses.size(); ++p) {
    const ImpulseResponse& response = responses[p];
    const Reconstruction& rec = recs[p];
    if (!rec.valid) continue;
    const double c0 = response.TotalLight();
    CircleCumulative truth_cdf{
        [&response](double tau) { return response.CumulativeOnCircle(tau, kPeriodS); },
        response.JumpsOnCircle(kPeriodS)};
    CircleCumulative rec_cdf{[&rec](double tau) { return rec.Cumulative(tau); },
                             rec.dirac_tau_s};
    emd_ns.push_back(CircleEmd(rec_cdf, truth_cdf, kPeriodS, options.emd_bins) / c0 * 1e9);
    if (std::isnan(rec.first_tau_s)) continue;
    ++found;
    const double true_tau = response.FirstReturnTau(options.range.threshold);
    // Range errors wrap to the nearest period of the method's own lowest frequency.
    const double error_s = WrapSymmetric(rec.first_tau_s - true_tau, rec.period_s);
    errors_mm.push_back(0.5 * kSpeedOfLight * error_s * 1e3);
  }
  row.found_share = static_cast<double>(found) / std::max(row.trials, 1);
  if (emd_ns.empty()) {
    row.emd_mean_ns = row.emd_median_ns = kNaN;
  } else {
    double sum = 0.0;
    for (double e : emd_ns) sum += e;
    row.emd_mean_ns = sum / emd_ns.size();
    row.emd_median_ns = Percentile(std::span<double>(emd_ns), 50.0);
  }
  row.range_error_mm = SummarizeErrors(errors_mm);
  row.within_1cm_share = static_cast<double>(row.range_error_mm.within_10) / std::max(row.trials, 1);
  row.time_per_pixel_us = seconds / std::max(row.trials, 1) * 1e6;
  return row;
}

std::vector<double> CurveOf(const Reconstruction& rec, const std::vector<double>& tau_ns,
                            double c0) {
  std::vector<double> curve;
  for (double t : tau_ns) curve.push_back(rec.valid ? rec.Cumulative(t * 1e-9) / c0 : kNaN);
  return curve;
}

// The methods of the pictures: the related ones and ours at the first order (thesis fig. 8.12
// uses m = 3), plus Pisarenko at m = 4 in the top view as in thesis fig. 8.13d.
std::vector<std::pair<MethodKind, int>> PictureMethods(const ExperimentOptions& options,
                                                       bool top_view) {
  std::vector<std::pair<MethodKind, int>> list;
  const int first = options.orders.empty() ? 3 : options.orders.front();
  for (MethodKind method : options.methods) {
    const bool ours = method == MethodKind::kMese || method == MethodKind::kPisarenko;
    list.emplace_back(method, ours ? first : 0);
    if (top_view && method == MethodKind::kPisarenko && first != 4 &&
        std::find(options.orders.begin(), options.orders.end(), 4) != options.orders.end()) {
      list.emplace_back(method, 4);
    }
  }
  return list;
}

}  // namespace

absl::StatusOr<ExperimentResult> RunExperiments(const ExperimentOptions& options,
                                                const ExperimentHooks& hooks) {
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  ExperimentResult result;

  auto is_ours = [](MethodKind m) { return m == MethodKind::kMese || m == MethodKind::kPisarenko; };
  // Configurations, for progress: per truth (and K), noise level, method and m.
  int64_t total = 0;
  for (TruthKind truth : options.truths) {
    const int64_t groups = truth == TruthKind::kKSparse ? options.orders.size() : 1;
    for (MethodKind method : options.methods) {
      const int64_t orders =
          is_ours(method) ? (truth == TruthKind::kKSparse ? 1 : options.orders.size()) : 1;
      total += groups * orders * options.noise.size();
    }
  }
  int64_t done = 0;

  CornerTruth corner;
  const bool need_corner = std::find(options.truths.begin(), options.truths.end(),
                                     TruthKind::kCorner) != options.truths.end();
  if (need_corner) {
    absl::StatusOr<CornerTruth> rendered =
        MakeCornerTruth(options.corner_width, options.corner_height);
    if (!rendered.ok()) {
      return absl::InternalError(
          absl::StrCat("cannot render the corner scene: ", rendered.status().message()));
    }
    corner = *std::move(rendered);
    if (corner.lit_pixels.empty()) return absl::InternalError("the corner scene has no lit pixel");
  }

  for (TruthKind truth : options.truths) {
    const std::vector<int> ks =
        truth == TruthKind::kKSparse ? options.orders : std::vector<int>{0};
    for (int k : ks) {
      if (hooks.on_stage) {
        hooks.on_stage(absl::StrCat("ground truth ", TruthName(truth),
                                    k > 0 ? absl::StrCat(" (K = ", k, ")") : "", ": ",
                                    options.trials, " trials per configuration"));
      }
      std::vector<ImpulseResponse> responses;
      if (truth == TruthKind::kCorner) {
        RandomStream random({options.seed, kCornerPixelStream});
        for (int t = 0; t < options.trials; ++t) {
          const size_t i = std::min<size_t>(
              static_cast<size_t>(random.Uniform() * corner.lit_pixels.size()),
              corner.lit_pixels.size() - 1);
          responses.push_back(corner.pixels[corner.lit_pixels[i]]);
        }
      } else {
        responses = SyntheticResponses(truth, k, options, options.trials, kTruthStream);
      }
      double outside = 0.0;
      for (const ImpulseResponse& r : responses) {
        outside = std::max(outside, r.LightOutside(kPeriodS) / r.TotalLight());
      }
      if (k == ks.front()) {
        result.light_outside.emplace_back(truth, outside);
      } else {  // the K-sparse truths share one entry
        result.light_outside.back().second = std::max(result.light_outside.back().second, outside);
      }

      for (bool noisy : options.noise) {
        for (MethodKind method : options.methods) {
          // The thesis's methods at every m; on the K-sparse truth only at m = K.
          std::vector<int> orders = {0};
          if (is_ours(method)) {
            orders = truth == TruthKind::kKSparse ? std::vector<int>{k} : options.orders;
          }
          for (int order : orders) {
            if (hooks.cancelled()) {
              return absl::CancelledError("transient eval interrupted");
            }
            double seconds = 0.0;
            const std::vector<Reconstruction> recs =
                Reconstruct(method, order, responses, noisy, options,
                            ConfigKey(truth, k, method, order, noisy), &seconds);
            result.rows.push_back(
                Evaluate(truth, k, method, order, noisy, responses, recs, seconds, options));
            hooks.Progress(++done, total);
          }
        }
      }

      // Pictures: fig. 8.12-style cumulatives of the first sparse and continuous responses.
      if (truth == TruthKind::kSparse || truth == TruthKind::kContinuous) {
        ExampleCurves example;
        example.truth = truth;
        const ImpulseResponse& response = responses.front();
        const double c0 = response.TotalLight();
        constexpr int kCurvePoints = 1024;
        for (int n = 0; n <= kCurvePoints; ++n) {
          example.tau_ns.push_back(kPeriodS * 1e9 * n / kCurvePoints);
          example.truth_curve.push_back(
              response.CumulativeOnCircle(kPeriodS * n / kCurvePoints, kPeriodS) / c0);
        }
        for (const auto& [method, order] : PictureMethods(options, false)) {
          CurveSet set;
          set.method = method;
          set.order = order;
          double ignored;
          const uint64_t key = ConfigKey(truth, 0, method, order, true) ^ (kExampleStream << 56);
          set.noise_free = CurveOf(
              Reconstruct(method, order, {response}, false, options, key, &ignored).front(),
              example.tau_ns, c0);
          const std::vector<ImpulseResponse> copies(options.example_noisy_draws, response);
          for (const Reconstruction& rec :
               Reconstruct(method, order, copies, true, options, key, &ignored)) {
            set.noisy.push_back(CurveOf(rec, example.tau_ns, c0));
          }
          example.methods.push_back(std::move(set));
        }
        result.examples.push_back(std::move(example));
      }
    }
  }

  if (need_corner) {
    // Pictures: fig. 8.13-style top view of the middle scanline.
    const int width = corner.camera.geometry.width;
    std::vector<ImpulseResponse> row;
    std::vector<int> columns;
    for (int u = 0; u < width; ++u) {
      const ImpulseResponse& r = corner.pixels[int64_t{corner.scanline_row} * width + u];
      if (r.returns.empty()) continue;
      row.push_back(r);
      columns.push_back(u);
    }
    auto point = [&](int u, double tau, std::vector<double>* x, std::vector<double>* z) {
      const std::array<double, 3> ray = CameraRay(corner.camera, u, corner.scanline_row);
      const double range = 0.5 * kSpeedOfLight * tau;  // NaN stays NaN: a gap in the plot
      x->push_back(ray[0] * range);
      z->push_back(ray[2] * range);
    };
    for (size_t i = 0; i < row.size(); ++i) {
      point(columns[i], row[i].FirstReturnTau(options.range.threshold),
            &result.top_view.truth_x_m, &result.top_view.truth_z_m);
    }
    for (const auto& [method, order] : PictureMethods(options, true)) {
      TopView::Points points;
      points.method = method;
      points.order = order;
      double ignored;
      const uint64_t key =
          ConfigKey(TruthKind::kCorner, 0, method, order, true) ^ (kTopViewStream << 56);
      const std::vector<Reconstruction> clean =
          Reconstruct(method, order, row, false, options, key, &ignored);
      const std::vector<Reconstruction> noisy =
          Reconstruct(method, order, row, true, options, key, &ignored);
      for (size_t i = 0; i < row.size(); ++i) {
        point(columns[i], clean[i].first_tau_s, &points.noise_free_x_m, &points.noise_free_z_m);
        point(columns[i], noisy[i].first_tau_s, &points.noisy_x_m, &points.noisy_z_m);
      }
      result.top_view.methods.push_back(std::move(points));
    }
  }
  if (options.run_multi_frequency) {
    if (hooks.on_stage) hooks.on_stage("the Kinect v2's frequencies on corner and mirrors");
    MultiFrequencyOptions multi = options.multi_frequency;
    multi.seed = options.seed;
    multi.snr = options.snr;
    absl::StatusOr<std::vector<MultiFrequencyRow>> rows = RunMultiFrequency(multi);
    if (!rows.ok()) return rows.status();
    result.multi_frequency = *std::move(rows);
  }
  result.seconds = SecondsSince<Clock>(start);
  return result;
}

}  // namespace transient::eval

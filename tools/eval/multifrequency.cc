// The Kinect v2's frequencies on the simulator's corner and mirrors scenes (multifrequency.h).
#include "tools/eval/multifrequency.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "tools/eval/baselines.h"
#include "tools/eval/ground_truth.h"
#include "transient/reconstruct/percentile.h"
#include "transient/reconstruct/phase_unwrapping.h"
#include "transient/reconstruct/physical_constants.h"

namespace transient::eval {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The Kinect v2: harmonics 2, 10, 15 of 8 MHz (16, 80, 120 MHz).
constexpr double kKinectBaseHz = 8e6;
const std::vector<int> kKinectHarmonics = {2, 10, 15};
// A range further than this from the truth is a wrong unwrap (the candidates of the 120 MHz
// phase are 1.25 m apart), not an inaccuracy.
constexpr double kWrapErrorM = 0.5;
// A stream of the benchmark's random numbers of its own (experiment.cc has 1-5).
constexpr uint64_t kMultiFrequencyNoiseStream = 11;

// Least-squares real weights >= 0 of two unit returns with phasors e1, e2 per harmonic, and
// the residual |m - a1 e1 - a2 e2|^2 (relative to |m|^2, which is left out: the same for all).
struct Fit {
  double cost = std::numeric_limits<double>::infinity();
  double a1 = 0.0, a2 = 0.0;
};

Fit FitPair(const Complex* m, const Complex* e1, const Complex* e2, size_t count) {
  double g11 = 0.0, g22 = 0.0, g12 = 0.0, h1 = 0.0, h2 = 0.0;
  for (size_t i = 0; i < count; ++i) {
    g11 += std::norm(e1[i]);
    g22 += std::norm(e2[i]);
    g12 += (std::conj(e1[i]) * e2[i]).real();
    h1 += (std::conj(e1[i]) * m[i]).real();
    h2 += (std::conj(e2[i]) * m[i]).real();
  }
  auto cost = [&](double a1, double a2) {
    return -2.0 * (a1 * h1 + a2 * h2) + a1 * a1 * g11 + a2 * a2 * g22 + 2.0 * a1 * a2 * g12;
  };
  const double det = g11 * g22 - g12 * g12;
  if (det > 1e-12 * g11 * g22) {
    const double a1 = (g22 * h1 - g12 * h2) / det, a2 = (g11 * h2 - g12 * h1) / det;
    if (a1 >= 0.0 && a2 >= 0.0) return {cost(a1, a2), a1, a2};
  }
  // A weight at the bound: one return alone.
  const double s1 = std::max(h1 / g11, 0.0), s2 = std::max(h2 / g22, 0.0);
  const double c1 = cost(s1, 0.0), c2 = cost(0.0, s2);
  return c1 <= c2 ? Fit{c1, s1, 0.0} : Fit{c2, 0.0, s2};
}

}  // namespace

std::string UnwrapMethodName(UnwrapMethod method) {
  switch (method) {
    case UnwrapMethod::kLibfreenect2:
      return "libfreenect2 unwrapping";
    case UnwrapMethod::kMaximumLikelihood:
      return "ML unwrapping (transientd)";
    case UnwrapMethod::kTwoReturn:
      return "two-return fit";
  }
  return "unknown";
}

double TwoReturnRange(const std::vector<Complex>& measurements, const std::vector<int>& harmonics,
                      double base_hz, double threshold) {
  const size_t count = measurements.size();
  double total = 0.0;
  for (const Complex& m : measurements) total += std::abs(m);
  if (!(total > 0.0)) return kNaN;
  constexpr int kGrid = 180;  // 2 degrees of the base frequency: 10.4 cm at 8 MHz
  std::vector<Complex> table(kGrid * count);
  for (int g = 0; g < kGrid; ++g) {
    for (size_t i = 0; i < count; ++i) {
      table[g * count + i] = std::polar(1.0, harmonics[i] * kTwoPi * g / kGrid);
    }
  }
  Fit best;
  double theta1 = 0.0, theta2 = 0.0;
  for (int g1 = 0; g1 < kGrid; ++g1) {
    for (int g2 = g1 + 1; g2 < kGrid; ++g2) {
      const Fit fit = FitPair(measurements.data(), &table[g1 * count], &table[g2 * count], count);
      if (fit.cost < best.cost) {
        best = fit;
        theta1 = kTwoPi * g1 / kGrid;
        theta2 = kTwoPi * g2 / kGrid;
      }
    }
  }
  // Coordinate search around the best pair, the step halving down to ~0.002 degrees.
  std::vector<Complex> e1(count), e2(count);
  auto evaluate = [&](double t1, double t2) {
    for (size_t i = 0; i < count; ++i) {
      e1[i] = std::polar(1.0, harmonics[i] * t1);
      e2[i] = std::polar(1.0, harmonics[i] * t2);
    }
    return FitPair(measurements.data(), e1.data(), e2.data(), count);
  };
  for (double step = kTwoPi / kGrid; step > 1e-5; step *= 0.5) {
    bool moved = true;
    while (moved) {
      moved = false;
      for (auto [d1, d2] : {std::pair{step, 0.0}, {-step, 0.0}, {0.0, step}, {0.0, -step}}) {
        const Fit fit = evaluate(theta1 + d1, theta2 + d2);
        if (fit.cost < best.cost - 1e-15 * total * total) {
          best = fit;
          theta1 += d1;
          theta2 += d2;
          moved = true;
        }
      }
    }
  }
  const double p1 = WrapPhase(theta1), p2 = WrapPhase(theta2);
  double first;
  if (best.a2 <= threshold * best.a1) {
    first = p1;
  } else if (best.a1 <= threshold * best.a2) {
    first = p2;
  } else {
    first = std::min(p1, p2);
  }
  return PhaseToRange(first, base_hz);
}

absl::StatusOr<std::vector<MultiFrequencyRow>> RunMultiFrequency(
    const MultiFrequencyOptions& options) {
  std::vector<MultiFrequencyRow> rows;
  const UnwrapOptions unwrap{.base_frequency_hz = kKinectBaseHz, .harmonics = kKinectHarmonics};
  for (size_t s = 0; s < options.scenes.size(); ++s) {
    absl::StatusOr<CornerTruth> truth =
        MakeSceneTruth(options.scenes[s], options.width, options.height);
    if (!truth.ok()) return truth.status();
    std::vector<int64_t> pixels;
    for (size_t i = 0; i < truth->lit_pixels.size(); i += static_cast<size_t>(options.pixel_stride)) {
      pixels.push_back(truth->lit_pixels[i]);
    }
    for (bool noisy : options.noise) {
      // The measurements of every pixel at 16, 80, 120 MHz (harmonics 2, 10, 15).
      std::vector<std::vector<Complex>> measured(pixels.size());
      std::vector<double> true_range(pixels.size());
      for (size_t n = 0; n < pixels.size(); ++n) {
        const ImpulseResponse& response = truth->pixels[static_cast<size_t>(pixels[n])];
        RandomStream random({options.seed, kMultiFrequencyNoiseStream, s, uint64_t(pixels[n])});
        const double sigma = response.TotalLight() / options.snr;
        for (int j : kKinectHarmonics) {
          Complex m = response.Measure(j * kKinectBaseHz);
          if (noisy) {
            const double re = sigma * random.Normal(), im = sigma * random.Normal();
            m += Complex(re, im);
          }
          measured[n].push_back(m);
        }
        true_range[n] = TimeOfFlightToRange(response.FirstReturnTau(0.1));
      }
      for (UnwrapMethod method : options.methods) {
        std::vector<double> range(pixels.size(), kNaN);
        const auto start = std::chrono::steady_clock::now();
        for (size_t n = 0; n < pixels.size(); ++n) {
          const std::vector<Complex>& m = measured[n];
          switch (method) {
            case UnwrapMethod::kLibfreenect2:
              range[n] = Libfreenect2Range(m[0], m[1], m[2]);
              break;
            case UnwrapMethod::kMaximumLikelihood: {
              const std::complex<float> c[3] = {
                  {static_cast<float>(m[0].real()), static_cast<float>(m[0].imag())},
                  {static_cast<float>(m[1].real()), static_cast<float>(m[1].imag())},
                  {static_cast<float>(m[2].real()), static_cast<float>(m[2].imag())}};
              range[n] = UnwrapPixel(c, unwrap).range_m;
              break;
            }
            case UnwrapMethod::kTwoReturn:
              range[n] = TwoReturnRange(m, kKinectHarmonics, kKinectBaseHz);
              break;
          }
        }
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        MultiFrequencyRow row;
        row.scene = options.scenes[s];
        row.method = method;
        row.noisy = noisy;
        row.pixels = static_cast<int>(pixels.size());
        std::vector<double> errors_mm, abs_mm;
        int found = 0, wrapped = 0;
        for (size_t n = 0; n < pixels.size(); ++n) {
          if (!std::isfinite(range[n]) || !std::isfinite(true_range[n])) continue;
          ++found;
          const double error = range[n] - true_range[n];
          if (std::abs(error) > kWrapErrorM) {
            ++wrapped;
            continue;
          }
          errors_mm.push_back(1e3 * error);
          abs_mm.push_back(1e3 * std::abs(error));
        }
        row.found_share = pixels.empty() ? 0.0 : static_cast<double>(found) / pixels.size();
        row.wrap_errors = found == 0 ? 0.0 : static_cast<double>(wrapped) / found;
        row.range_error_mm = SummarizeErrors(errors_mm);
        row.median_abs_mm = abs_mm.empty() ? kNaN : Percentile(abs_mm, 50.0);
        row.time_per_pixel_us = pixels.empty() ? 0.0 : 1e6 * seconds / pixels.size();
        rows.push_back(row);
      }
    }
  }
  return rows;
}

}  // namespace transient::eval

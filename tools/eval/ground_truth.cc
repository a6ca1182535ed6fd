// Closed-form ground truths of the quality benchmark (ground_truth.h).
#include "tools/eval/ground_truth.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>

namespace transient::eval {
namespace {

constexpr double kSqrt2 = std::numbers::sqrt2;

// Past this argument erfc underflows to subnormals (erfc(26.5) ~ 1e-307); beyond it the
// asymptotic series of erfcx(x) = exp(x^2) erfc(x) is accurate to ~1e-9.
constexpr double kErfcxSwitch = 25.0;

double Erfcx(double x) {
  if (x < kErfcxSwitch) return std::exp(x * x) * std::erfc(x);
  const double inv2 = 1.0 / (x * x);
  return (1.0 - 0.5 * inv2 + 0.75 * inv2 * inv2) / (x * std::sqrt(std::numbers::pi));
}

// exp(-rate*(t - tau) + rate^2 sigma^2/2) * Phi(z - rate*sigma): the exponential term of the EMG
// CDF, and the EMG density divided by the rate. With B = (rate*sigma - z)/sqrt(2) the exponent is
// B^2 - z^2/2, so for large B it is written as exp(-z^2/2) erfcx(B)/2, which cannot overflow.
double EmgTerm(double z, double rate_sigma) {
  const double b = (rate_sigma - z) / kSqrt2;
  if (b < kErfcxSwitch) return std::exp(b * b - 0.5 * z * z) * 0.5 * std::erfc(b);
  return std::exp(-0.5 * z * z) * 0.5 * Erfcx(b);
}

bool IsDirac(const Return& r) { return r.sigma_s == 0.0 && r.decay_rate == 0.0; }

// An interval holding all but ~1e-17 of a return's light.
void Support(const Return& r, double* low, double* high) {
  *low = r.tau_s - 10.0 * r.sigma_s;
  *high = r.tau_s + 10.0 * r.sigma_s + (r.decay_rate > 0.0 ? 40.0 / r.decay_rate : 0.0);
}

}  // namespace

double ReturnCdf(const Return& r, double t) {
  const double x = t - r.tau_s;
  if (IsDirac(r)) return x > 0.0 ? 1.0 : 0.0;  // P(t' < t): the jump belongs to what follows
  if (r.sigma_s == 0.0) return x > 0.0 ? -std::expm1(-r.decay_rate * x) : 0.0;
  const double z = x / r.sigma_s;
  const double normal = 0.5 * std::erfc(-z / kSqrt2);
  if (r.decay_rate == 0.0) return normal;
  return std::clamp(normal - EmgTerm(z, r.decay_rate * r.sigma_s), 0.0, 1.0);
}

double ReturnDensity(const Return& r, double t) {
  const double x = t - r.tau_s;
  if (IsDirac(r)) return 0.0;
  if (r.sigma_s == 0.0) return x >= 0.0 ? r.decay_rate * std::exp(-r.decay_rate * x) : 0.0;
  const double z = x / r.sigma_s;
  if (r.decay_rate == 0.0) {
    return std::exp(-0.5 * z * z) / (r.sigma_s * std::sqrt(2.0 * std::numbers::pi));
  }
  return r.decay_rate * EmgTerm(z, r.decay_rate * r.sigma_s);
}

double ReturnMode(const Return& r) {
  if (r.sigma_s == 0.0 || r.decay_rate == 0.0) return r.tau_s;
  // The EMG is log-concave, hence unimodal, and its mode lies in [tau, tau + 1/rate]: the
  // bracket below holds it with room to spare.
  const double scale = r.sigma_s + 1.0 / r.decay_rate;
  double a = r.tau_s - 3.0 * r.sigma_s, b = r.tau_s + 3.0 * scale;
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = b - golden * (b - a), d = a + golden * (b - a);
  double fc = ReturnDensity(r, c), fd = ReturnDensity(r, d);
  while (b - a > 1e-6 * scale) {
    if (fc > fd) {
      b = d, d = c, fd = fc;
      c = b - golden * (b - a), fc = ReturnDensity(r, c);
    } else {
      a = c, c = d, fc = fd;
      d = a + golden * (b - a), fd = ReturnDensity(r, d);
    }
  }
  return 0.5 * (a + b);
}

double ImpulseResponse::TotalLight() const {
  double total = 0.0;
  for (const Return& r : returns) total += r.amplitude;
  return total;
}

Complex ImpulseResponse::Measure(double frequency_hz) const {
  Complex sum(0.0, 0.0);
  for (const Return& r : returns) {
    sum += r.amplitude * SceneReturnCharacteristicFunction(r, kTwoPi * frequency_hz);
  }
  return sum;
}

double ImpulseResponse::CumulativeOnCircle(double tau_s, double period_s) const {
  double sum = 0.0;
  for (const Return& r : returns) {
    if (IsDirac(r)) {
      const double wrapped = r.tau_s - std::floor(r.tau_s / period_s) * period_s;
      if (wrapped < tau_s) sum += r.amplitude;
      continue;
    }
    double low, high;
    Support(r, &low, &high);
    const int64_t first = static_cast<int64_t>(std::floor(low / period_s));
    const int64_t last = static_cast<int64_t>(std::floor(high / period_s));
    double light = 0.0;
    for (int64_t k = first; k <= last; ++k) {
      light += ReturnCdf(r, k * period_s + tau_s) - ReturnCdf(r, k * period_s);
    }
    sum += r.amplitude * light;
  }
  return sum;
}

double ImpulseResponse::LightOutside(double period_s) const {
  double sum = 0.0;
  for (const Return& r : returns) {
    if (IsDirac(r)) {
      if (r.tau_s < 0.0 || r.tau_s >= period_s) sum += r.amplitude;
      continue;
    }
    sum += r.amplitude * (ReturnCdf(r, 0.0) + 1.0 - ReturnCdf(r, period_s));
  }
  return sum;
}

std::vector<double> ImpulseResponse::JumpsOnCircle(double period_s) const {
  std::vector<double> jumps;
  for (const Return& r : returns) {
    if (IsDirac(r)) jumps.push_back(r.tau_s - std::floor(r.tau_s / period_s) * period_s);
  }
  return jumps;
}

double ImpulseResponse::FirstReturnTau(double threshold) const {
  double largest = 0.0;
  for (const Return& r : returns) largest = std::max(largest, r.amplitude);
  for (const Return& r : returns) {  // sorted by tau
    if (r.amplitude > 0.0 && r.amplitude >= threshold * largest) return ReturnMode(r);
  }
  return kNaN;
}

std::vector<double> SeparatedDelays(int count, double low, double high, double separation,
                                    RandomStream& random) {
  // Uniform over the set of sorted delays with gaps >= separation: sorted uniform points in a
  // shortened interval, the i-th shifted right by i gaps.
  const double room = high - low - (count - 1) * separation;
  assert(count >= 1 && room > 0.0);
  std::vector<double> delays(count);
  for (double& d : delays) d = random.Uniform(0.0, room);
  std::sort(delays.begin(), delays.end());
  for (int i = 0; i < count; ++i) delays[i] += low + i * separation;
  return delays;
}

ImpulseResponse RandomSparse(int count, const SyntheticTruthOptions& options,
                             RandomStream& random) {
  ImpulseResponse response;
  for (double tau : SeparatedDelays(count, options.first_delay_s, options.last_delay_s,
                                    options.min_separation_s, random)) {
    response.returns.push_back({tau, random.Uniform(options.min_weight, options.max_weight)});
  }
  return response;
}

ImpulseResponse RandomContinuous(int count, const SyntheticTruthOptions& options,
                                 RandomStream& random) {
  ImpulseResponse response;
  for (double tau : SeparatedDelays(count, options.first_onset_s, options.last_onset_s,
                                    options.min_separation_s, random)) {
    Return r;
    r.tau_s = tau;
    r.amplitude = random.Uniform(options.min_weight, options.max_weight);
    r.sigma_s = random.Uniform(options.min_sigma_s, options.max_sigma_s);
    r.decay_rate = 1.0 / random.Uniform(options.min_tail_s, options.max_tail_s);
    response.returns.push_back(r);
  }
  return response;
}

ImpulseResponse RandomKSparse(int k, const SyntheticTruthOptions& options, RandomStream& random) {
  ImpulseResponse response;
  for (double tau : SeparatedDelays(k, options.ksparse_margin_s,
                                    kPeriodS - options.ksparse_margin_s,
                                    options.ksparse_min_separation_s, random)) {
    response.returns.push_back({tau, random.Uniform(options.min_weight, options.max_weight)});
  }
  return response;
}

absl::StatusOr<CornerTruth> MakeCornerTruth(int width, int height) {
  return MakeSceneTruth("corner", width, height);
}

absl::StatusOr<CornerTruth> MakeSceneTruth(absl::string_view scene_name, int width, int height) {
  SimulatorOptions options;
  options.scene = std::string(scene_name);
  options.width = width;
  options.height = height;
  absl::StatusOr<SceneReturns> scene = RenderSceneReturns(options);
  if (!scene.ok()) return scene.status();
  CornerTruth truth;
  truth.camera = scene->camera;
  const int64_t pixels = truth.camera.geometry.pixel_count();
  truth.pixels.resize(pixels);
  for (int64_t p = 0; p < pixels; ++p) {
    for (const SceneReturn& r : scene->pixel(p)) truth.pixels[p].returns.push_back(r);
    if (!truth.pixels[p].returns.empty()) truth.lit_pixels.push_back(p);
  }
  truth.scanline_row = height / 2;
  return truth;
}

}  // namespace transient::eval

// Signal formation (thesis §8.2.1) with the sub-exposure split of thesis §8.3.1.
#include "forward_model.h"

#include <cmath>

namespace transient::sim {
namespace {

// Relative size below which the terms of a continuous return's Fourier series are dropped.
constexpr double kSeriesTolerance = 1e-9;

}  // namespace

ForwardModel::ForwardModel(const SimulatorOptions& options, const AcquisitionSchedule& schedule,
                           FixedPattern pattern)
    : schedule_(schedule.options()),
      exposures_(schedule.exposures().begin(),
                 schedule.exposures().begin() + schedule.exposures_per_take()),
      pattern_(std::move(pattern)),
      modulation_(options.waveform, options.duty, schedule.sub_exposures()) {
  for (int e = 0; e < static_cast<int>(exposures_.size()); ++e) {
    const double nu = exposures_[e].frequency_hz;
    if (nu == 0.0) continue;
    FrequencyGroup* group = nullptr;
    for (FrequencyGroup& g : groups_) {
      if (g.frequency_hz == nu) group = &g;
    }
    if (group == nullptr) {
      groups_.push_back({nu, {}});
      group = &groups_.back();
    }
    group->exposures.push_back(e);
  }
}

void ForwardModel::Evaluate(const ReturnPlanes& returns, ExposureSignals* out) const {
  const ImageGeometry g = returns.geometry;
  out->geometry = g;
  out->light.assign(g.pixel_count(), 0.0f);
  out->differential.resize(exposures_.size());
  for (auto& plane : out->differential) plane.assign(g.pixel_count(), 0.0f);
#pragma omp parallel if (g.pixel_count() > 50000)
  {
    std::vector<Complex> scratch;
#pragma omp for schedule(static)
    for (int v = 0; v < g.height; ++v) {
      for (int u = 0; u < g.width; ++u)
        EvaluatePixel(returns, int64_t{v} * g.width + u, out, &scratch);
    }
  }
}

void ForwardModel::EvaluatePixel(const ReturnPlanes& returns, int64_t p, ExposureSignals* out,
                                 std::vector<Complex>* scratch) const {
  const double exposure = schedule_.exposure_s;
  double light = 0.0;
  for (int r = 0; r < returns.max_returns; ++r) light += returns.amplitude[returns.index(r, p)];
  light *= exposure;
  out->light[p] = static_cast<float>(light);
  for (size_t e = 0; e < exposures_.size(); ++e) {
    if (exposures_[e].frequency_hz == 0.0) {
      out->differential[e][p] = exposures_[e].illumination ? static_cast<float>(light) : 0.0f;
    }
  }
  if (light == 0.0) return;

  const double gain = pattern_.gain[p];
  const double delay = pattern_.delay_s[p];
  for (const FrequencyGroup& group : groups_) {
    const double nu = group.frequency_hz;
    double sums[kMaxPhaseBuckets] = {};  // per exposure of the group (its N buckets)
    const int count = static_cast<int>(group.exposures.size());
    for (int r = 0; r < returns.max_returns; ++r) {
      const int64_t i = returns.index(r, p);
      const double a = returns.amplitude[i];
      if (a == 0.0) continue;
      if (!returns.continuous(i)) {
        const double phase = kTwoPi * nu * (static_cast<double>(returns.tau_s[i]) + delay);
        for (int k = 0; k < count; ++k) {
          sums[k] += a * modulation_(phase - exposures_[group.exposures[k]].phase_shift_rad);
        }
        continue;
      }
      // V_h = T_h exp(i*h*2*pi*nu*d) phi(h*nu); the buckets then only rotate it.
      scratch->clear();
      const auto coefficients = modulation_.coefficients();
      for (int h = 1; h <= modulation_.highest_harmonic(); ++h) {
        const double omega = kTwoPi * h * nu;
        const Complex phi = CharacteristicFunction(returns, i, omega);
        if (std::abs(phi) * modulation_.tail_bound(h) <
            kSeriesTolerance * std::abs(coefficients[1])) {
          break;
        }
        scratch->push_back(coefficients[h] * std::polar(1.0, omega * delay) * phi);
      }
      for (int k = 0; k < count; ++k) {
        const Complex rotation = std::polar(1.0, -exposures_[group.exposures[k]].phase_shift_rad);
        Complex power = rotation, sum(0.0, 0.0);
        for (const Complex& term : *scratch) {
          sum += term * power;
          power *= rotation;
        }
        sums[k] += a * 2.0 * sum.real();
      }
    }
    for (int k = 0; k < count; ++k) {
      out->differential[group.exposures[k]][p] = static_cast<float>(gain * exposure * sums[k]);
    }
  }
}

MomentImage ForwardModel::TrueMoments(const ReturnPlanes& returns, double scale) const {
  const int m = schedule_.order;
  MomentImage moments(returns.geometry, m);
  const int64_t count = returns.geometry.pixel_count();
  for (int64_t p = 0; p < count; ++p) {
    for (int j = 0; j <= m; ++j) {
      Complex c(0.0, 0.0);
      for (int r = 0; r < returns.max_returns; ++r) {
        const int64_t i = returns.index(r, p);
        if (returns.amplitude[i] == 0.0f) continue;
        c += static_cast<double>(returns.amplitude[i]) *
             CharacteristicFunction(returns, i, kTwoPi * j * schedule_.base_frequency_hz);
      }
      c *= scale * schedule_.exposure_s;
      moments.real_plane(j)[p] = static_cast<float>(c.real());
      moments.imag_plane(j)[p] = static_cast<float>(j == 0 ? 0.0 : c.imag());
    }
  }
  return moments;
}

}  // namespace transient::sim

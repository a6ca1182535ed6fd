// Range from the first MESE peak or Pisarenko return (thesis §8.4.3).
#include "transient/reconstruct/range.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

#include "absl/container/inlined_vector.h"
#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/polynomial.h"

namespace transient {
namespace {

constexpr int kRangeNewtonSteps = 8;
// Newton stops below this step: 1e-10 rad is 1e-8 m of range at 23 MHz, and the step after a
// step this small is below rounding anyway (quadratic convergence).
constexpr double kPhaseTolerance = 1e-10;

// Refines the minimum of the denominator near grid phase `center` (spacing h): Newton on its
// derivative while the curvature is positive and the iterate stays within one bin; otherwise
// the vertex of the parabola through the three grid values. Newton runs on the cosine series
// `a`: its cancellation near a sharp minimum spoils the value (~u/eps^2 relative) but not the
// location, whose error is ~u m^3 rad; values are compared through `p` (Horner) instead.
double RefineMinimum(std::span<const Complex> a, std::span<const Complex> p, double center,
                     double h, double left, double middle, double right) {
  double phase = center;
  for (int step = 0; step < kRangeNewtonSteps; ++step) {
    const SeriesValue s = EvaluateDenominatorSeries(a, phase);
    if (!(s.second > 0.0)) break;
    const double delta = -s.first / s.second;
    phase += delta;
    if (!(std::abs(phase - center) <= h)) break;
    if (std::abs(delta) < kPhaseTolerance) return phase;
  }
  if (phase != center && std::abs(phase - center) <= h &&
      std::norm(EvaluatePolynomial(p, std::polar(1.0, phase))) <= middle) {
    return phase;
  }
  const double curvature = left - 2.0 * middle + right;
  const double offset = curvature > 0.0 ? 0.5 * (left - right) / curvature : 0.0;
  return center + std::clamp(offset, -1.0, 1.0) * h;
}

}  // namespace

double MeseFirstPeakPhase(std::span<const Complex> q, double threshold, int search_bins) {
  assert(search_bins >= 3);
  // Peaks of D are minima of the positive denominator |p|^2; on the grid only its value is
  // needed, so p alone is evaluated there.
  std::array<Complex, kMaxMoments> p_storage;
  const std::span<Complex> p(p_storage.data(), q.size());
  for (size_t j = 0; j < q.size(); ++j) p[j] = std::conj(q[j]);
  std::vector<double> r(search_bins);
  const double h = kTwoPi / search_bins;
  for (int n = 0; n < search_bins; ++n) {
    r[n] = std::norm(EvaluatePolynomial(p, std::polar(1.0, n * h)));
  }
  return MeseFirstPeakFromGrid(q, threshold, r);
}

double MeseFirstPeakFromGrid(std::span<const Complex> q, double threshold,
                             std::span<const double> r) {
  std::array<Complex, kMaxMoments> a;
  MeseDenominatorSeries(q, std::span<Complex>(a.data(), q.size()));
  return MeseFirstPeakFromGrid(q, std::span<const Complex>(a.data(), q.size()), threshold, r);
}

double MeseFirstPeakFromGrid(std::span<const Complex> q, std::span<const Complex> a,
                             double threshold, std::span<const double> r) {
  const int search_bins = static_cast<int>(r.size());
  assert(search_bins >= 3);
  const double h = kTwoPi / search_bins;
  std::array<Complex, kMaxMoments> p_storage;
  const std::span<Complex> p(p_storage.data(), q.size());
  for (size_t j = 0; j < q.size(); ++j) p[j] = std::conj(q[j]);
  // A degree-m trigonometric polynomial has at most m minima: no allocation in practice.
  absl::InlinedVector<MesePeak, kMaxOrder> peaks;
  for (int n = 0; n < search_bins; ++n) {
    const double left = r[n == 0 ? search_bins - 1 : n - 1];
    const double right = r[n + 1 == search_bins ? 0 : n + 1];
    if (!(r[n] < left && r[n] <= right)) continue;
    const double phase = RefineMinimum(a, p, n * h, h, left, r[n], right);
    const double denominator = std::norm(EvaluatePolynomial(p, std::polar(1.0, phase)));
    if (!(denominator > 0.0)) continue;  // only underflow can get here: D would be infinite
    peaks.push_back({OrderingPhase(phase), denominator,
                     MesePeakLight(denominator, EvaluateDenominatorSeries(a, phase).second), n});
  }
  return MeseFirstReturn(peaks, threshold, r);
}

double MesePeakLight(double denominator, double second_derivative) {
  // The pole's term q_0 / (2 pi (A - B cos(phi - phi_0))) with A - B = r and B = r'' at the
  // peak: its integral over the period is q_0 / sqrt(A^2 - B^2), its floor (at phi_0 + pi)
  // 2 pi q_0 / (2 pi (A + B)) over the period. Per unit q_0, the light above the floor.
  // (A curvature that is not positive, NaN included, gives a flat top: no light above it.)
  const double top = denominator + 2.0 * (second_derivative > 0.0 ? second_derivative : 0.0);
  return 1.0 / std::sqrt(denominator * top) - 1.0 / top;
}

double MeseFirstReturn(std::span<const MesePeak> peaks, double threshold,
                       std::span<const double> r) {
  if (peaks.empty()) return std::numeric_limits<double>::quiet_NaN();
  // D = q_0 / (2 pi r): the highest density has the smallest denominator.
  double smallest = std::numeric_limits<double>::infinity(), brightest = 0.0;
  for (const MesePeak& peak : peaks) {
    smallest = std::min(smallest, peak.denominator);
    brightest = std::max(brightest, peak.light);
  }
  const int count = static_cast<int>(peaks.size());
  const int bins = static_cast<int>(r.size());
  // The highest grid denominator (the lowest density) from bin `from` up to, not including,
  // bin `to`, cyclically.
  const auto valley = [&](int from, int to) {
    double highest = 0.0;
    for (int n = from; n != to; n = n + 1 == bins ? 0 : n + 1) highest = std::max(highest, r[n]);
    return highest;
  };
  double first = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < count; ++i) {
    const MesePeak& peak = peaks[i];
    if (peak.phase >= first) continue;
    // D_p >= threshold * D_max  <=>  threshold * r_p <= r_min
    bool passes = threshold * peak.denominator <= smallest;
    if (!passes && count > 1 && peak.light > 0.0 && peak.light >= threshold * brightest) {
      // Its light counts where the peak stands apart: the density falls to threshold x its
      // height or below on both sides before the neighbouring peaks.
      // (A bin outside the grid, which only a caller's mistake gives, never passes by light:
      // the valleys would be read out of it.)
      const int before = peaks[i == 0 ? count - 1 : i - 1].bin;
      const int after = peaks[i + 1 == count ? 0 : i + 1].bin;
      const auto on_grid = [bins](int bin) { return bin >= 0 && bin < bins; };
      passes = on_grid(before) && on_grid(peak.bin) && on_grid(after) &&
               peak.denominator <= threshold * valley(before, peak.bin) &&
               peak.denominator <= threshold * valley(peak.bin, after);
    }
    if (passes) first = peak.phase;
  }
  return first;
}

double PisarenkoFirstReturnPhase(const PisarenkoEstimate& estimate, double threshold, int* index) {
  if (index != nullptr) *index = -1;
  double largest = 0.0;
  for (int l = 0; l < estimate.count; ++l) largest = std::max(largest, estimate.weight[l]);
  double first = std::numeric_limits<double>::quiet_NaN();
  for (int l = 0; l < estimate.count; ++l) {
    if (!(estimate.weight[l] > 0.0 && estimate.weight[l] >= threshold * largest)) continue;
    const double phase = OrderingPhase(estimate.phase[l]);
    if (!(phase >= first)) {
      first = phase;
      if (index != nullptr) *index = l;
    }
  }
  return first;
}

}  // namespace transient

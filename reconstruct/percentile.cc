// Type-7 percentiles by two partial sorts.
#include "transient/reconstruct/percentile.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace transient {
namespace {

template <typename T>
double PercentileOf(std::span<T> values, double percent) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  assert(std::none_of(values.begin(), values.end(), [](T v) { return std::isnan(v); }));
  const double rank = std::clamp(percent, 0.0, 100.0) / 100.0 * double(values.size() - 1);
  const size_t lower = std::min(static_cast<size_t>(rank), values.size() - 1);
  std::nth_element(values.begin(), values.begin() + lower, values.end());
  const double low = values[lower];
  if (lower + 1 == values.size()) return low;
  // After nth_element everything above `lower` is >= values[lower]; the next rank is their min.
  const double high = *std::min_element(values.begin() + lower + 1, values.end());
  if (high == low) return low;  // also two equal infinities, whose difference is NaN
  return low + (rank - static_cast<double>(lower)) * (high - low);
}

}  // namespace

double Percentile(std::span<double> values, double percent) {
  return PercentileOf(values, percent);
}

double Percentile(std::span<float> values, double percent) {
  return PercentileOf(values, percent);
}

}  // namespace transient

// Earth mover's distance on the circle and error summaries (metrics.h).
#include "tools/eval/metrics.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

#include "transient/reconstruct/percentile.h"

namespace transient::eval {

double CircleEmd(const CircleCumulative& a, const CircleCumulative& b, double period_s,
                 int bins) {
  assert(bins >= 1 && period_s > 0.0);
  std::vector<double> cuts;
  cuts.reserve(bins + 1 + a.jumps_s.size() + b.jumps_s.size());
  for (int n = 0; n <= bins; ++n) cuts.push_back(period_s * n / bins);
  for (const std::vector<double>* jumps : {&a.jumps_s, &b.jumps_s}) {
    for (double t : *jumps) {
      if (t > 0.0 && t < period_s) cuts.push_back(t);
    }
  }
  std::sort(cuts.begin(), cuts.end());
  // (difference at the cell's midpoint, cell width)
  std::vector<std::pair<double, double>> cells;
  cells.reserve(cuts.size());
  double total_width = 0.0;
  for (size_t n = 0; n + 1 < cuts.size(); ++n) {
    const double width = cuts[n + 1] - cuts[n];
    if (!(width > 0.0)) continue;
    const double mid = 0.5 * (cuts[n] + cuts[n + 1]);
    cells.emplace_back(a.value(mid) - b.value(mid), width);
    total_width += width;
  }
  // The weighted median of the difference minimizes the weighted L1 distance to a constant.
  std::vector<std::pair<double, double>> sorted = cells;
  std::sort(sorted.begin(), sorted.end());
  double alpha = sorted.empty() ? 0.0 : sorted.back().first, accumulated = 0.0;
  for (const auto& [difference, width] : sorted) {
    accumulated += width;
    if (accumulated >= 0.5 * total_width) {
      alpha = difference;
      break;
    }
  }
  double sum = 0.0;
  for (const auto& [difference, width] : cells) sum += width * std::abs(difference - alpha);
  return sum;
}

double WrapSymmetric(double x, double period) {
  return x - period * std::floor(x / period + 0.5);
}

ErrorSummary SummarizeErrors(std::span<const double> errors) {
  ErrorSummary summary;
  summary.count = static_cast<int>(errors.size());
  if (errors.empty()) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    summary.mean = summary.rmse = summary.p95_abs = nan;
    return summary;
  }
  double sum = 0.0, squares = 0.0;
  std::vector<double> magnitudes;
  magnitudes.reserve(errors.size());
  for (double e : errors) {
    sum += e;
    squares += e * e;
    magnitudes.push_back(std::abs(e));
    if (std::abs(e) <= 10.0) ++summary.within_10;
  }
  summary.mean = sum / errors.size();
  summary.rmse = std::sqrt(squares / errors.size());
  summary.p95_abs = Percentile(std::span<double>(magnitudes), 95.0);
  return summary;
}

}  // namespace transient::eval

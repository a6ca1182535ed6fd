// Metrics of the quality benchmark: the earth mover's distance between two distributions of
// time of flight on the circle of one modulation period, and summaries of range errors.
#pragma once

#include <functional>
#include <span>
#include <vector>

namespace transient::eval {

// A cumulative distribution on the circle [0, T): value(tau) is the light with time of flight
// in [0, tau) for tau in [0, T] (so value(0) = 0); jumps_s lists where it jumps (Dirac masses),
// each in [0, T). Between jumps it must be continuous.
struct CircleCumulative {
  std::function<double(double tau_s)> value;
  std::vector<double> jumps_s;
};

// Earth mover's distance on the circle of period T between the measures of `a` and `b`:
//   min over alpha of integral_0^T |F_a(tau) - F_b(tau) - alpha| dtau
// (Rabin, Delon & Gousseau 2011: on a circle the optimal transport cost is the L1 distance of
// the cumulatives up to the best constant, because the cut point is free). The optimal alpha is
// the median of F_a - F_b over [0, T). Equal total masses are assumed for it to be a transport
// cost; otherwise it is the L1 distance of the cumulatives up to a constant, which still counts
// missing or extra light. Unit: the unit of F times seconds.
//
// The integral uses the midpoint rule on `bins` uniform cells, each cut again at every jump of
// either cumulative: exact where both are step functions, error O((T/bins)^2) times the density
// elsewhere, and at most (T/bins) times the light in one cell for sharp peaks.
double CircleEmd(const CircleCumulative& a, const CircleCumulative& b, double period_s,
                 int bins);

// x wrapped into [-period/2, period/2).
double WrapSymmetric(double x, double period);

// Mean, root mean square and 95th percentile of the absolute value of `errors` (NaN for none).
struct ErrorSummary {
  int count = 0;
  double mean = 0.0, rmse = 0.0, p95_abs = 0.0;
  int within_10 = 0;  // errors with |e| <= 10 (1 cm when the errors are in mm)
};
ErrorSummary SummarizeErrors(std::span<const double> errors);


}  // namespace transient::eval

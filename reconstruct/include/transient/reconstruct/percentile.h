// The one percentile of the project: latency statistics (the daemon's and the client's p50 and
// p99 are the same statistic), colour scales of pictures, error summaries of the quality
// benchmark.
#pragma once

#include <span>

namespace transient {

// The `percent`-th percentile (0..100) of `values`, linear between the closest ranks (Hyndman
// & Fan type 7, numpy's default): rank r = percent/100 * (n - 1), value v[floor(r)] +
// (r - floor(r)) * (v[floor(r) + 1] - v[floor(r)]) of the sorted values. 0 gives the minimum,
// 100 the maximum, a single value every percentile; NaN for no values. Reorders `values` (a
// partial sort, O(n)). `percent` outside [0, 100] is clamped; NaN among the values is not
// allowed (asserted in debug builds): drop non-finite values first.
double Percentile(std::span<double> values, double percent);
double Percentile(std::span<float> values, double percent);

}  // namespace transient

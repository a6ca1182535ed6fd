// Related methods of the quality benchmark (thesis §8.5, fig. 8.12/8.13): single-frequency
// phase, the two-Dirac closed form of Godbaz et al., SPUMIC and SRA, from their papers'
// descriptions.
#include "tools/eval/baselines.h"

#include <glpk.h>

#include <Eigen/Core>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/physical_constants.h"
#include "transient/reconstruct/polynomial.h"

namespace transient::eval {
namespace {

// Returns whose least-squares weight is at most this fraction of the largest measurement
// magnitude are dropped: far below any noise level of the benchmark (SNR 70:1, thesis
// fig. 8.12), far above rounding (~1e-16), so a spurious root of an over-modelled fit goes.
constexpr double kNegligibleWeight = 1e-9;

// GodbazTwoDirac treats its 2x2 Prony system as singular (one return) when
// |m1 m3 - m2^2| <= this times max|m_k|^2. For two returns the determinant is
// a1 a2 z1 z2 (z1 - z2)^2, so this only merges returns whose a1 a2 |z1 - z2|^2 is below
// 1e-12 of the squared signal, where the two-return solution is rounding noise anyway.
constexpr double kSingularProny = 1e-12;

// Sra keeps grid bins with x_n > kSraKeptFraction * sum x. A basic LP solution has at most
// 2K + 1 non-zero variables; this only removes the simplex's rounding dust.
constexpr double kSraKeptFraction = 1e-6;

struct TimedReturn {
  double time_s;
  double weight;
};

bool IsPositiveFrequency(double frequency_hz) {
  return std::isfinite(frequency_hz) && frequency_hz > 0.0;
}

// Time of flight of `phase` (radians) at `frequency_hz`, wrapped into [0, 1/frequency_hz).
double PhaseToWrappedTime(double phase, double frequency_hz) {
  const double period_s = 1.0 / frequency_hz;
  const double time_s = WrapPhase(phase) / kTwoPi * period_s;
  // WrapPhase < 2*pi, but the division may still round up to the period itself.
  return time_s < period_s ? time_s : 0.0;
}

// Wraps a time of flight into [0, period_s).
double WrapTime(double time_s, double period_s) {
  return PhaseToWrappedTime(kTwoPi * (time_s / period_s), 1.0 / period_s);
}

// Sorted by time. Drops what breaks the header's guarantees, which only extreme inputs can
// produce (weights that overflow when scaled back to near-DBL_MAX measurements).
SparseReturns ToSparseReturns(std::vector<TimedReturn> returns) {
  std::sort(returns.begin(), returns.end(),
            [](const TimedReturn& a, const TimedReturn& b) { return a.time_s < b.time_s; });
  SparseReturns result;
  for (const TimedReturn& r : returns) {
    if (!(std::isfinite(r.time_s) && std::isfinite(r.weight) && r.weight > 0.0)) continue;
    result.time_of_flight_s.push_back(r.time_s);
    result.weight.push_back(r.weight);
  }
  return result;
}

// Real least-squares weights of unit returns at `times_s` for m(f_k), f_k = (k+1) * base:
//   minimize sum_k |sum_l w_l exp(i 2 pi f_k tau_l) - m_k|^2 over real w.
// Why real and not |complex least squares|: the true weights are real and positive (amounts of
// light), so the real fit is the least-squares estimate under the model; the magnitude of a
// complex fit would turn every phase error into extra brightness and never reach zero, and
// its real part is not the constrained optimum when the returns' Gram matrix is complex.
// Column-pivoted QR gives zero weights to returns that are linearly dependent on others.
Eigen::VectorXd FitRealWeights(std::span<const Complex> measurements, double base_frequency_hz,
                               std::span<const double> times_s) {
  const int k_count = static_cast<int>(measurements.size());
  const int l_count = static_cast<int>(times_s.size());
  Eigen::MatrixXd a(2 * k_count, l_count);
  Eigen::VectorXd b(2 * k_count);
  for (int k = 0; k < k_count; ++k) {
    for (int l = 0; l < l_count; ++l) {
      const double phase = kTwoPi * (k + 1) * base_frequency_hz * times_s[l];
      a(2 * k, l) = std::cos(phase);
      a(2 * k + 1, l) = std::sin(phase);
    }
    b(2 * k) = measurements[k].real();
    b(2 * k + 1) = measurements[k].imag();
  }
  return a.colPivHouseholderQr().solve(b);
}

// Fits real weights to the candidate times and drops returns whose weight is not above
// `negligible` (noise makes some negative), refitting the rest until all are positive.
std::vector<TimedReturn> FitPositiveReturns(std::span<const Complex> measurements,
                                       double base_frequency_hz, std::vector<double> times_s,
                                       double negligible) {
  while (!times_s.empty()) {
    const Eigen::VectorXd weights = FitRealWeights(measurements, base_frequency_hz, times_s);
    std::vector<double> kept_times;
    std::vector<TimedReturn> returns;
    for (size_t l = 0; l < times_s.size(); ++l) {
      if (weights[l] > negligible) {  // false for NaN too
        kept_times.push_back(times_s[l]);
        returns.push_back({times_s[l], weights[l]});
      }
    }
    if (kept_times.size() == times_s.size()) return returns;
    times_s = std::move(kept_times);
  }
  return {};
}

double LargestMagnitude(std::span<const Complex> values) {
  double largest = 0.0;
  for (const Complex& v : values) largest = std::max(largest, std::abs(v));
  return largest;
}

absl::Status ValidateHarmonicInput(absl::string_view method, std::span<const Complex> measurements,
                                   double base_frequency_hz) {
  if (!IsPositiveFrequency(base_frequency_hz)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: base_frequency_hz = %g. Violated constraint: finite and > 0", method,
                        base_frequency_hz));
  }
  for (size_t k = 0; k < measurements.size(); ++k) {
    if (!IsFinite(measurements[k])) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: measurement %d (at %d * base frequency) is not finite", method, k, k + 1));
    }
  }
  return absl::OkStatus();
}

// Times of flight of the unit-circle projections of `roots` at base frequency f.
std::vector<double> RootTimes(std::span<const Complex> roots, double base_frequency_hz) {
  std::vector<double> times_s;
  for (const Complex& z : roots) {
    if (!IsFinite(z)) continue;
    times_s.push_back(PhaseToWrappedTime(std::arg(z), base_frequency_hz));
  }
  return times_s;
}

// Cadzow's denoising: alternately project the sequence's Hankel matrix onto rank `rank`
// (truncated SVD) and back onto Hankel structure (anti-diagonal means). The matrix is the most
// square one, (K - M) x (M + 1) with M = K / 2, where truncation removes the most noise.
void CadzowDenoise(int rank, int iterations, Eigen::VectorXcd& m) {
  const int k_count = static_cast<int>(m.size());
  const int cols = k_count / 2 + 1;
  const int rows = k_count - cols + 1;
  if (std::min(rows, cols) <= rank) return;  // already of rank <= `rank`: nothing to remove
  for (int iteration = 0; iteration < iterations; ++iteration) {
    Eigen::MatrixXcd hankel(rows, cols);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) hankel(i, j) = m[i + j];
    }
    Eigen::JacobiSVD<Eigen::MatrixXcd> svd(hankel, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::MatrixXcd low_rank = svd.matrixU().leftCols(rank) *
                                      svd.singularValues().head(rank).asDiagonal() *
                                      svd.matrixV().leftCols(rank).adjoint();
    Eigen::VectorXcd sums = Eigen::VectorXcd::Zero(k_count);
    Eigen::VectorXd counts = Eigen::VectorXd::Zero(k_count);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) {
        sums[i + j] += low_rank(i, j);
        counts[i + j] += 1.0;
      }
    }
    m = sums.cwiseQuotient(counts.cast<Complex>());
  }
}

// GLPK objects freed on every path.
struct GlpProbDeleter {
  void operator()(glp_prob* problem) const { glp_delete_prob(problem); }
};
using GlpProb = std::unique_ptr<glp_prob, GlpProbDeleter>;

// GLPK keeps one environment per thread (in thread-local storage) and frees it only in
// glp_free_env(): without this, every worker thread of the benchmark that calls Sra would leak
// it (~5 KB, which LeakSanitizer reports). One per thread, made on its first Sra call and
// destroyed when the thread exits. (It would also free GLPK objects that other code left alive
// in that thread at its exit; nothing else in the project uses GLPK.)
struct GlpThreadEnvironment {
  ~GlpThreadEnvironment() { glp_free_env(); }
};

// Silences GLPK's terminal output (per thread) for one call and restores the previous setting.
class GlpTerminalSilencer {
 public:
  GlpTerminalSilencer() : previous_(glp_term_out(GLP_OFF)) {}
  ~GlpTerminalSilencer() { glp_term_out(previous_); }
  GlpTerminalSilencer(const GlpTerminalSilencer&) = delete;
  GlpTerminalSilencer& operator=(const GlpTerminalSilencer&) = delete;

 private:
  int previous_;
};

absl::Status ValidateSraArguments(std::span<const double> frequencies_hz,
                                  std::span<const Complex> measurements, double epsilon,
                                  int grid_bins) {
  if (frequencies_hz.empty()) {
    return absl::InvalidArgumentError("Sra: no frequencies. Violated constraint: at least one");
  }
  if (frequencies_hz.size() != measurements.size()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("Sra: %d frequencies but %d measurements. Violated constraint: same length",
                        frequencies_hz.size(), measurements.size()));
  }
  for (size_t k = 0; k < frequencies_hz.size(); ++k) {
    if (!IsPositiveFrequency(frequencies_hz[k])) {
      return absl::InvalidArgumentError(
          absl::StrFormat("Sra: frequencies_hz[%d] = %g. Violated constraint: finite and > 0", k,
                          frequencies_hz[k]));
    }
    if (!IsFinite(measurements[k])) {
      return absl::InvalidArgumentError(absl::StrFormat("Sra: measurements[%d] is not finite", k));
    }
  }
  if (!(epsilon > 0.0 && epsilon < 1.0)) {  // also rejects NaN
    return absl::InvalidArgumentError(
        absl::StrFormat("Sra: epsilon = %g. Violated constraint: 0 < epsilon < 1", epsilon));
  }
  if (grid_bins < kMinSraGridBins || grid_bins > kMaxSraGridBins) {
    return absl::InvalidArgumentError(
        absl::StrFormat("Sra: grid_bins = %d. Violated constraint: %d <= grid_bins <= %d",
                        grid_bins, kMinSraGridBins, kMaxSraGridBins));
  }
  return absl::OkStatus();
}

}  // namespace

SparseReturns SingleFrequencyPhase(Complex measurement, double frequency_hz) {
  if (!IsPositiveFrequency(frequency_hz) || !IsFinite(measurement) || measurement == Complex(0.0)) {
    return {};
  }
  return ToSparseReturns(
      {{PhaseToWrappedTime(std::arg(measurement), frequency_hz), std::abs(measurement)}});
}

// Source: Godbaz, Cree & Dorrington (2012) invert the two-return model in closed form from
// four harmonic measurements; the paper was not at hand, and this is the Prony-type closed form
// of the same model (exact for noise-free two-return data, like theirs).
absl::StatusOr<SparseReturns> GodbazTwoDirac(std::span<const Complex> measurements,
                                             double base_frequency_hz) {
  if (measurements.size() != 4) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "GodbazTwoDirac: %d measurements. Violated constraint: exactly 4 (m(f)..m(4f))",
        measurements.size()));
  }
  if (absl::Status status =
          ValidateHarmonicInput("GodbazTwoDirac", measurements, base_frequency_hz);
      !status.ok()) {
    return status;
  }
  const double scale = LargestMagnitude(measurements);
  if (scale == 0.0) return SparseReturns{};
  // Scale-free from here on: products of four measurements neither overflow nor underflow.
  Complex m[4];
  for (int k = 0; k < 4; ++k) m[k] = measurements[k] / scale;
  const std::span<const Complex> normalized(m, 4);

  // [m2 -m1; m3 -m2] [s; p] = [m3; m4] (1-based m_k as in the header), by Cramer's rule.
  const Complex determinant = m[0] * m[2] - m[1] * m[1];
  std::vector<double> times_s;
  if (std::abs(determinant) <= kSingularProny) {
    // One return: the one-pole least-squares Prony fit m_{k+1} = z m_k, k = 1..3.
    Complex numerator = 0.0;
    double denominator = 0.0;
    for (int k = 0; k < 3; ++k) {
      numerator += std::conj(m[k]) * m[k + 1];
      denominator += std::norm(m[k]);
    }
    if (denominator == 0.0) return SparseReturns{};  // only m4 != 0: no single return fits
    const Complex z = numerator / denominator;
    times_s = RootTimes(std::span<const Complex>(&z, 1), base_frequency_hz);
  } else {
    const Complex s = (m[0] * m[3] - m[1] * m[2]) / determinant;
    const Complex p = (m[1] * m[3] - m[2] * m[2]) / determinant;
    // Roots of z^2 - s z + p without cancellation: the larger from the root of the
    // discriminant aligned with s, the smaller from z1 z2 = p.
    Complex root_discriminant = std::sqrt(s * s - 4.0 * p);
    if ((std::conj(s) * root_discriminant).real() < 0.0) root_discriminant = -root_discriminant;
    const Complex z1 = 0.5 * (s + root_discriminant);
    const Complex z2 = z1 == Complex(0.0) ? Complex(0.0) : p / z1;
    const Complex roots[2] = {z1, z2};
    times_s = RootTimes(roots, base_frequency_hz);
  }
  std::vector<TimedReturn> returns =
      FitPositiveReturns(normalized, base_frequency_hz, std::move(times_s), kNegligibleWeight);
  for (TimedReturn& r : returns) r.weight *= scale;
  return ToSparseReturns(std::move(returns));
}

// Source: the SPUMIC paper (ICME 2013) was not at hand. Its abstract describes parametric
// modelling of multipath over several harmonic frequencies and "robust spectral estimation
// methods with low computational complexity"; the standard such estimator for K samples of a
// sum of L exponentials is the total-least-squares annihilating filter, optionally after
// Cadzow denoising (the FRI toolbox of the authors' community). Cadzow is off by default: the
// thesis reports SPUMIC as quite sensitive to noise (§8.5.1), as the plain estimator is.
absl::StatusOr<SparseReturns> Spumic(std::span<const Complex> measurements,
                                     double base_frequency_hz, int returns, int cadzow_iterations) {
  if (returns < 1 || returns > kMaxSpumicReturns) {
    return absl::InvalidArgumentError(
        absl::StrFormat("Spumic: returns = %d. Violated constraint: 1 <= returns <= %d", returns,
                        kMaxSpumicReturns));
  }
  const int k_count = static_cast<int>(measurements.size());
  if (k_count < 2 * returns) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "Spumic: %d measurements for %d returns. Violated constraint: K >= 2 * returns", k_count,
        returns));
  }
  if (cadzow_iterations < 0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "Spumic: cadzow_iterations = %d. Violated constraint: >= 0", cadzow_iterations));
  }
  if (absl::Status status = ValidateHarmonicInput("Spumic", measurements, base_frequency_hz);
      !status.ok()) {
    return status;
  }
  const double scale = LargestMagnitude(measurements);
  if (scale == 0.0) return SparseReturns{};
  Eigen::VectorXcd m(k_count);
  for (int k = 0; k < k_count; ++k) m[k] = measurements[k] / scale;
  const std::vector<Complex> normalized(m.data(), m.data() + k_count);

  // Cadzow denoises the data used for the filter; the weights are fitted to the measurements.
  CadzowDenoise(returns, cadzow_iterations, m);

  // Annihilating filter: sum_j h_j m_{i+j} = 0 for all rows i, so sum_j h_j z^j vanishes at
  // each z_l. The right singular vector of the smallest singular value is the total-least-
  // squares h; with K = 2 * returns the matrix is wide and that vector spans its null space.
  const int rows = k_count - returns;
  Eigen::MatrixXcd hankel(rows, returns + 1);
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j <= returns; ++j) hankel(i, j) = m[i + j];
  }
  Eigen::JacobiSVD<Eigen::MatrixXcd> svd(hankel, Eigen::ComputeFullV);
  const Eigen::VectorXcd filter = svd.matrixV().col(returns);
  std::vector<Complex> roots(returns);
  const int root_count = PolynomialRoots(
      std::span<const Complex>(filter.data(), static_cast<size_t>(returns + 1)), roots);
  std::vector<double> times_s =
      RootTimes(std::span<const Complex>(roots).first(root_count), base_frequency_hz);

  std::vector<TimedReturn> result =
      FitPositiveReturns(normalized, base_frequency_hz, std::move(times_s), kNegligibleWeight);
  for (TimedReturn& r : result) r.weight *= scale;
  return ToSparseReturns(std::move(result));
}

// Source: the SRA paper (ECCV 2014) was not at hand; this follows its abstract ("robust
// techniques based on L1 optimization" over a dictionary of returns) and the thesis's remark
// that SRA is biased towards sparsity and less brightness (§8.5.1). The paper's dictionary also
// has diffuse (Lambertian) profiles and its fast variant a learned dimension reduction; neither
// is used here: the benchmark compares the sparse-return model at fig. 8.12's parameters.
//
// The LP, in the scale-free units v <- v / ||v||_1 (weights are scaled back at the end):
//   variables  x_n >= 0 (n < N), r+_i >= 0, r-_i >= 0 (i < 2K)
//   minimize   sum_n x_n
//   subject to sum_n Phi_in x_n + r+_i - r-_i = v_i        (2K equality rows)
//              sum_i (r+_i + r-_i) <= epsilon              (one row)
// At the optimum min(r+_i, r-_i) = 0, so the last row is ||Phi x - v||_1 <= epsilon ||v||_1.
// The L1 data term keeps it an LP (SRA's choice of an L1-based robust fit); the thesis's
// epsilon = 0.05 is read as relative to the data's size, which makes it scale-free. All costs
// are >= 0, so the slack basis is dual feasible and the dual simplex starts right away.
//
// The weight bound in the header: x = (1 - epsilon) a e_n0 is feasible, so sum x <= (1 -
// epsilon) a. For a lower bound take the dual certificate w_k = (cos, sin)(theta_k) / mu_k with
// mu_k = max(|cos theta_k|, |sin theta_k|) (so ||w||_inf <= 1): w . (v - Phi x) <= ||v - Phi x||_1
// and w . phi_n <= w . phi_n0 = sum_k 1 / mu_k give sum x >= a (1 - epsilon rho) with
// rho = sum_k (|cos| + |sin|) / sum_k (1 / mu_k) <= max_theta mu (|cos| + |sin|) = (1 + sqrt 2)/2
// ~ 1.207 (rho = 1 for theta_k all multiples of pi/2, e.g. tau = 0).
absl::StatusOr<SparseReturns> Sra(std::span<const double> frequencies_hz,
                                  std::span<const Complex> measurements, double epsilon,
                                  int grid_bins) {
  if (absl::Status status = ValidateSraArguments(frequencies_hz, measurements, epsilon, grid_bins);
      !status.ok()) {
    return status;
  }
  const int k_count = static_cast<int>(frequencies_hz.size());
  const double lowest_hz = *std::min_element(frequencies_hz.begin(), frequencies_hz.end());
  const double period_s = 1.0 / lowest_hz;

  std::vector<double> v(2 * k_count);
  double scale = 0.0;
  for (int k = 0; k < k_count; ++k) {
    v[2 * k] = measurements[k].real();
    v[2 * k + 1] = measurements[k].imag();
    scale += std::abs(v[2 * k]) + std::abs(v[2 * k + 1]);
  }
  if (scale == 0.0) return SparseReturns{};  // x = 0 is the optimum
  for (double& value : v) value /= scale;

  [[maybe_unused]] thread_local const GlpThreadEnvironment glp_environment;
  const GlpTerminalSilencer silencer;
  const GlpProb problem(glp_create_prob());
  glp_prob* lp = problem.get();
  glp_set_obj_dir(lp, GLP_MIN);
  const int data_rows = 2 * k_count;
  const int tolerance_row = data_rows + 1;  // GLPK indices are 1-based
  glp_add_rows(lp, data_rows + 1);
  for (int i = 0; i < data_rows; ++i) glp_set_row_bnds(lp, i + 1, GLP_FX, v[i], v[i]);
  glp_set_row_bnds(lp, tolerance_row, GLP_UP, 0.0, epsilon);
  const int residual_columns = 2 * data_rows;
  glp_add_cols(lp, grid_bins + residual_columns);
  for (int column = 1; column <= grid_bins + residual_columns; ++column) {
    glp_set_col_bnds(lp, column, GLP_LO, 0.0, 0.0);
    glp_set_obj_coef(lp, column, column <= grid_bins ? 1.0 : 0.0);
  }

  // Constraint matrix as 1-based triplets (GLPK ignores index 0); exact zeros are left out.
  std::vector<int> row_index(1), column_index(1);
  std::vector<double> value(1);
  const auto add = [&](int row, int column, double coefficient) {
    if (coefficient == 0.0) return;
    row_index.push_back(row);
    column_index.push_back(column);
    value.push_back(coefficient);
  };
  for (int n = 0; n < grid_bins; ++n) {
    const double bin_fraction = static_cast<double>(n) / grid_bins;  // tau_n / period
    for (int k = 0; k < k_count; ++k) {
      const double phase = kTwoPi * (frequencies_hz[k] / lowest_hz) * bin_fraction;
      add(2 * k + 1, n + 1, std::cos(phase));
      add(2 * k + 2, n + 1, std::sin(phase));
    }
  }
  for (int i = 0; i < data_rows; ++i) {
    const int plus = grid_bins + 2 * i + 1;
    add(i + 1, plus, 1.0);
    add(i + 1, plus + 1, -1.0);
    add(tolerance_row, plus, 1.0);
    add(tolerance_row, plus + 1, 1.0);
  }
  glp_load_matrix(lp, static_cast<int>(value.size()) - 1, row_index.data(), column_index.data(),
                  value.data());

  glp_smcp parameters;
  glp_init_smcp(&parameters);
  parameters.msg_lev = GLP_MSG_OFF;
  parameters.meth = GLP_DUALP;
  if (const int code = glp_simplex(lp, &parameters); code != 0) {
    return absl::InternalError(
        absl::StrFormat("Sra: GLPK glp_simplex failed with return code %d", code));
  }
  const int lp_status = glp_get_status(lp);
  if (lp_status == GLP_NOFEAS) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "Sra: no non-negative combination of %d grid returns fits the measurements within "
        "epsilon = %g",
        grid_bins, epsilon));
  }
  if (lp_status != GLP_OPT) {
    return absl::InternalError(
        absl::StrFormat("Sra: GLPK ended with solution status %d, not optimal", lp_status));
  }

  std::vector<double> x(grid_bins);
  double total = 0.0;
  for (int n = 0; n < grid_bins; ++n) {
    x[n] = std::max(0.0, glp_get_col_prim(lp, n + 1));
    total += x[n];
  }
  const double kept = kSraKeptFraction * total;
  // Merge runs of adjacent kept bins, cyclically: start after a dropped bin so that no run is
  // cut at the wrap. A Dirac between grid points comes out of the LP as its two neighbours, so
  // their weighted mean is a sub-bin estimate of its time.
  int start = 0;
  while (start < grid_bins && x[start] > kept) ++start;
  if (start == grid_bins) start = 0;  // every bin kept (only for tiny grids): one run
  std::vector<TimedReturn> returns;
  double run_weight = 0.0, run_moment = 0.0;
  const double bin_s = period_s / grid_bins;
  const auto close_run = [&] {
    if (run_weight > 0.0) {
      returns.push_back({WrapTime(run_moment / run_weight * bin_s, period_s), run_weight * scale});
    }
    run_weight = run_moment = 0.0;
  };
  for (int offset = 1; offset <= grid_bins; ++offset) {
    const int unwrapped = start + offset;  // bin index without wrapping, for the mean
    const double weight = x[unwrapped % grid_bins];
    if (weight > kept) {
      run_weight += weight;
      run_moment += weight * unwrapped;
    } else {
      close_run();
    }
  }
  close_run();
  return ToSparseReturns(std::move(returns));
}

double Libfreenect2Range(Complex m16, Complex m80, Complex m120) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  // Rule 9: phases in [0, 2*pi); NaN (no light) counts as 0.
  auto phase = [&](Complex m) {
    double theta = std::atan2(m.imag(), m.real());
    if (theta < 0.0) theta += kTwoPi;
    return std::isnan(theta) ? 0.0 : theta;
  };
  // Rules 14-20, with the code's truncated constants.
  const double t0 = phase(m80) / kTwoPi * 3.0;
  const double t1 = phase(m16) / kTwoPi * 15.0;
  const double t2 = phase(m120) / kTwoPi * 2.0;
  const double t5 = std::floor((t1 - t0) * 0.333333 + 0.5) * 3.0 + t0;
  const double d = t5 - t2;
  const double r = d >= 0.0 ? (d / 2.0 - std::floor(d / 2.0)) * 2.0
                            : (-d / 2.0 - std::floor(-d / 2.0)) * -2.0;
  const bool c2 = 0.5 < std::abs(r) && std::abs(r) < 1.5;
  double t6 = c2 ? t5 + 15.0 : t5;
  double t7 = c2 ? t1 + 15.0 : t1;
  const double t8 = (std::floor((t6 - t2) * 0.5 + 0.5) * 2.0 + t2) * 0.5;
  t6 *= 0.333333;
  t7 *= 0.066667;
  const double t9 = t8 + t6 + t7;
  const double t10 = t9 < 0.0 ? 0.0 : t9 * 0.333333;
  // Rules 21-23: the consistency of the three unwrapped phases.
  const double v6 = kTwoPi * t6, v7 = kTwoPi * t7, v8 = kTwoPi * t8;
  const double a = 0.826977 * v7 - 0.110264 * v8;
  const double b = 0.551318 * v8 - 0.826977 * v6;
  const double c = 0.110264 * v6 - 0.551318 * v7;
  const double norm = a * a + b * b + c * c;
  constexpr double kConfidence = 0.3490659;  // min_dealias_confidence: bright pixels
  if (!(kConfidence * kConfidence >= norm) || !(t10 > 0.0)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return t10 / 9.0 * UnambiguousRange(8e6);
}

}  // namespace transient::eval

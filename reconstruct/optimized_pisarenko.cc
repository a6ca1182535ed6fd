// The Pisarenko estimate by a faster route (issue 17): the decomposition of Pisarenko()
// (pisarenko.cc; thesis alg. 8.2 and §8.4.1) computed without a dense eigen-solve, a companion
// matrix or a QR decomposition, which Eigen does in general-purpose code that took most of the
// reference's ~10 µs a pixel at m = 3 (with the sines and cosines of its residuals):
//
// 1. lambda_min by Newton's method on Levinson's recursion (thesis alg. 8.1) for
//    C(c) - lambda I (the approach of Cybenko and Van Loan 1986). With
//    q(lambda) = (C - lambda I)^{-1} e_0, f(lambda) = 1 / q_0 is the last prediction error
//    det C_m(lambda) / det C_{m-1}(lambda), positive below lambda_min, negative between it and
//    the leading minor's lambda_min, zero at lambda_min. d/dlambda (C - lambda I)^{-1} =
//    (C - lambda I)^{-2} gives f' = -|q|^2 / q_0^2, so Newton's step is q_0 / |q|^2, which
//    near lambda_min is the distance left to it. From below, lambda + q_0 / |q|^2 is the
//    Rayleigh quotient of q, so the step lands at or above lambda_min; from above, the steps
//    approached it monotonically in every case traced. ShiftedLevinson says on which side an
//    iterate is, and a step that leaves the bracket is bisected instead. q then points along
//    the eigenvector of lambda_min (q ~ u conj(u_0) / (lambda_min - lambda)), as in inverse
//    iteration. Steps from just below the leading minor's lambda_min (a pole of f) are short;
//    on frames of three returns with noise this takes 5.6, 8.8 and 10.9 recursions a pixel
//    at m = 3, 4 and 8.
// 2. The roots of P(x) = sum_j conj(q_j) x^j, all on the unit circle for a simple lambda_min
//    (Pisarenko 1973), bracketed by the sign changes of a real function of the phase: the
//    eigenvector of a Hermitian Toeplitz matrix is conjugate-persymmetric,
//    q_{m-j} = e^{i theta} conj(q_j), so R(phi) = Re(e^{i theta/2} P(e^{i phi}) e^{-i m phi/2})
//    is P on the circle rotated onto the real axis. Its sign on a grid of 16 (m+1) phases
//    (tabled once per image) brackets the roots; Newton's method on P itself, from the point
//    of the bracket's chord, refines each without a sine or cosine.
// 3. The weights and the Gauss-Newton polish solve the reference's least-squares problems by
//    their normal equations (a small Cholesky factorisation), whose matrices are sums of
//    products of the returns' powers; the polish stops once the moment equations hold to
//    1e-13 c_0.
//
// A pixel for which any step cannot vouch for its result (C(c) not positive definite at the
// start, no convergence, a degenerate lambda_min, two roots within one grid step, an
// ill-conditioned normal matrix) returns false, and the caller runs Pisarenko() on it. The
// results are the reference's to ~1e-11 (below the float planes' rounding): the accuracy
// contract of tests/reconstruct/kernels_test.cc.
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>

#include "kernels_internal.h"
#include "kernels_simd.h"
#include "levinson_lanes.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/pisarenko.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient {
namespace {

constexpr int kMaxLambdaSteps = 64;  // Newton converges in ~5; bisection halves at worst
constexpr int kMaxRootSteps = 30;
constexpr double kRootTolerance = 1e-13;  // |Newton step| on P
// A root of the eigenvector's polynomial this far from the unit circle means lambda_min was
// not found (the reference drops such roots as spurious; here the pixel goes to it).
constexpr double kUnitCircleTolerance = 1e-6;
constexpr double kLambdaTolerance = 1e-12;  // relative to c_0
// |q_m| = |q_0| for the eigenvector of a simple lambda_min (persymmetry); a larger difference
// means a degenerate lambda_min or no convergence.
constexpr double kPersymmetryTolerance = 1e-6;
// Smallest Cholesky pivot, relative to the largest diagonal entry, accepted from a normal
// matrix: below it the system is too ill-conditioned for the normal equations' squared
// condition number, and the reference's pivoted QR takes the pixel.
constexpr double kSmallestPivot = 1e-12;
// As in pisarenko.cc: returns lighter than this share of the sparse mass are dropped.
constexpr double kNegligibleWeight = 1e-10;
constexpr int kPolishSteps = 3;              // as pisarenko.cc
constexpr double kPolishedResidual = 1e-13;  // relative to c_0

// Solves a x = b for the symmetric positive definite n x n `a` (row-major, only its lower
// triangle read) by Cholesky's factorisation in place; false when a pivot is below
// kSmallestPivot of the largest diagonal entry. Written out rather than Eigen's LLT, whose
// dynamic-size bookkeeping cost more than the arithmetic at these sizes (n <= 2 kMaxOrder).
bool SolveNormal(int n, double* a, double* b) {
  double largest = 0.0;
  for (int i = 0; i < n; ++i) largest = std::max(largest, a[i * n + i]);
  double inverse[2 * kMaxOrder];  // 1 / L_ii: one division per row, the rest products
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k <= i; ++k) {
      double sum = a[i * n + k];
      for (int j = 0; j < k; ++j) sum -= a[i * n + j] * a[k * n + j];
      if (k < i) {
        a[i * n + k] = sum * inverse[k];
      } else {
        if (!(sum > kSmallestPivot * largest)) return false;  // also NaN
        inverse[i] = 1.0 / std::sqrt(sum);
      }
    }
  }
  for (int i = 0; i < n; ++i) {  // L y = b
    double sum = b[i];
    for (int j = 0; j < i; ++j) sum -= a[i * n + j] * b[j];
    b[i] = sum * inverse[i];
  }
  for (int i = n - 1; i >= 0; --i) {  // L^T x = y
    double sum = b[i];
    for (int j = i + 1; j < n; ++j) sum -= a[j * n + i] * b[j];
    b[i] = sum * inverse[i];
  }
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(b[i])) return false;
  }
  return true;
}

// Returns phi_l with weights w_l, e^{i j phi_l} (j = 0..m) and the residual of the moment
// equations sum_l w_l e^{i j phi_l} - b_j. Plain doubles, so that nothing is zeroed on the
// way (a std::complex is, and these arrays would cost more to clear than to use).
struct Returns {
  double phase[kMaxOrder];
  double unit_re[kMaxOrder];  // cos phi_l
  double unit_im[kMaxOrder];  // sin phi_l
  double weight[kMaxOrder];
  double re[kMaxOrder][kMaxMoments];  // cos j phi_l
  double im[kMaxOrder][kMaxMoments];  // sin j phi_l
  double residual_re[kMaxMoments];
  double residual_im[kMaxMoments];
  double residual_norm;  // squared
};

// The powers of n returns of order m from their e^{i phi_l}.
void SetPowers(int m, int n, Returns* r) {
  for (int l = 0; l < n; ++l) {
    const double x = r->unit_re[l], y = r->unit_im[l];
    double pr = 1.0, pi = 0.0;
    for (int j = 0; j <= m; ++j) {
      r->re[l][j] = pr;
      r->im[l][j] = pi;
      const double next = pr * x - pi * y;
      pi = pr * y + pi * x;
      pr = next;
    }
  }
}

void SetResidual(int m, int n, const double* b_re, const double* b_im, Returns* r) {
  double norm = 0.0;
  for (int j = 0; j <= m; ++j) {
    double x = -b_re[j], y = -b_im[j];
    for (int l = 0; l < n; ++l) {
      x += r->weight[l] * r->re[l][j];
      y += r->weight[l] * r->im[l][j];
    }
    r->residual_re[j] = x;
    r->residual_im[j] = y;
    norm += x * x + y * y;
  }
  r->residual_norm = norm;
}

}  // namespace

PisarenkoSearchGrid::PisarenkoSearchGrid(int m) : order_(m), size_(16 * (m + 1)) {
  assert(m >= 1 && m <= kMaxOrder);
  re_.resize(static_cast<size_t>((m + 1) * size_));
  im_.resize(re_.size());
  unit_re_.resize(size_);
  unit_im_.resize(size_);
  for (int g = 0; g < size_; ++g) {
    unit_re_[g] = std::cos(kTwoPi * g / size_);
    unit_im_[g] = std::sin(kTwoPi * g / size_);
  }
  for (int j = 0; j <= m; ++j) {
    for (int g = 0; g < size_; ++g) {
      const double angle = (j - 0.5 * m) * kTwoPi * g / size_;
      re_[j * size_ + g] = std::cos(angle);
      im_[j * size_ + g] = std::sin(angle);
    }
  }
}

bool PisarenkoByLevinson(std::span<const Complex> c, const PisarenkoSearchGrid& grid,
                         PisarenkoEstimate* estimate) {
  const int size = static_cast<int>(c.size());
  const int m = size - 1;
  assert(m == grid.order());
  const double c0 = c[0].real();
  if (!(c0 > 0.0) || !std::isfinite(c0)) return false;

  // 1. lambda_min (header comment): Newton's steps on f = 1 / q_0 within the bracket
  // [below, above], bisection where a step would leave it.
  std::array<Complex, kMaxMoments> q_storage, trial_storage;
  std::span<Complex> q(q_storage.data(), size), trial(trial_storage.data(), size);
  double below = -std::numeric_limits<double>::infinity();  // C - below I positive definite
  double above = c0;  // lambda_min <= e_0^* C e_0 = c_0; lowered to each iterate past it
  double lambda = 0.0;
  LevinsonOutcome outcome = ShiftedLevinson(c, lambda, q);
  if (outcome == LevinsonOutcome::kFailed) {
    // Beyond the leading minor's lambda_min: start from Gershgorin's bound on lambda_min.
    double off_diagonal = 0.0;
    for (int j = 1; j < size; ++j) off_diagonal += 2.0 * std::abs(c[j]);
    above = lambda;
    lambda = c0 - off_diagonal - 1e-9 * c0;
    outcome = ShiftedLevinson(c, lambda, q);
    if (outcome != LevinsonOutcome::kPositiveDefinite) return false;
  }
  // Newton's step estimates the distance left to lambda_min; rounding in Levinson's recursion
  // near a singular matrix keeps it from falling much below ~eps c_0, so stop at this, after
  // which the step itself is added (quadratic convergence: its own error is far smaller).
  const double tolerance = kLambdaTolerance * c0;
  double lambda_min = std::numeric_limits<double>::quiet_NaN();
  for (int step = 0; step < kMaxLambdaSteps; ++step) {
    if (outcome == LevinsonOutcome::kPositiveDefinite) {
      below = std::max(below, lambda);
    } else {
      above = std::min(above, lambda);
    }
    double norm = 0.0;
    for (int j = 0; j < size; ++j) norm += std::norm(q[j]);
    const double newton = q[0].real() / norm;
    if (std::abs(newton) <= tolerance) {
      lambda_min = lambda + newton;
      break;
    }
    double next = lambda + newton;
    if (!(next > below && next < above)) {
      if (!(above - below > tolerance)) {
        lambda_min = 0.5 * (below + above);
        break;
      }
      next = std::isfinite(below) ? 0.5 * (below + above) : above - 2.0 * (above - lambda);
    }
    const LevinsonOutcome next_outcome = ShiftedLevinson(c, next, trial);
    if (next_outcome == LevinsonOutcome::kFailed) {
      if (next < lambda) {  // from above, within (lambda_min, lambda): singular to rounding
        lambda_min = next;
        break;
      }
      above = next;  // past the leading minor's lambda_min: stay at lambda, bisect
      continue;
    }
    lambda = next;
    outcome = next_outcome;
    std::swap(q, trial);
  }
  if (!std::isfinite(lambda_min)) return false;

  // 2. The roots on the unit circle. Normalised by q_0 so that the eigenvector is O(1).
  // q_0 is real (Levinson); |q_m| / |q_0| compared squared (q is O(1/distance), no overflow).
  const double q0 = std::abs(q[0].real());
  if (!(std::abs(std::norm(q[m]) / (q0 * q0) - 1.0) < 2.0 * kPersymmetryTolerance)) return false;
  const Complex rotation = std::sqrt(q[m] / std::conj(q[0]));  // e^{i theta / 2}
  // P(x) = sum_j p_j x^j, p_j = conj(q_j) / |q_0|; R(phi) = Re e^{i theta/2} P(e^{i phi})
  // e^{-i m phi/2}.
  double p_re[kMaxMoments], p_im[kMaxMoments];
  for (int j = 0; j <= m; ++j) {
    p_re[j] = q[j].real() / q0;
    p_im[j] = -q[j].imag() / q0;
  }
  const int points = grid.size();
  double values[16 * kMaxMoments];
  for (int g = 0; g < points; ++g) values[g] = 0.0;
  for (int j = 0; j <= m; ++j) {
    const double* re = grid.real(j);
    const double* im = grid.imag(j);
    const Complex aj = rotation * Complex(p_re[j], p_im[j]);
    const double ar = aj.real(), ai = aj.imag();
    for (int g = 0; g < points; ++g) values[g] += ar * re[g] - ai * im[g];
  }
  // R(phi + 2 pi) = (-1)^m R(phi): the interval after the last grid point ends at -R(0) for odd m.
  const double last = (m % 2 == 0) ? values[0] : -values[0];
  const double spacing = kTwoPi / points;
  double root_re[kMaxOrder], root_im[kMaxOrder], phases[kMaxOrder];
  int n = 0;
  for (int g = 0; g < points; ++g) {
    const double left_value = values[g];
    const double right_value = (g + 1 < points) ? values[g + 1] : last;
    if ((left_value < 0.0) == (right_value < 0.0)) continue;
    if (n == m) return false;  // more sign changes than roots: rounding at a double root
    // Newton's method on P itself, from the chord point between the grid's two points put
    // back on the circle: no sine or cosine, quadratic convergence to the simple root.
    const int h = (g + 1) % points;
    const double t = left_value / (left_value - right_value);
    double x = (1.0 - t) * grid.unit_real(g) + t * grid.unit_real(h);
    double y = (1.0 - t) * grid.unit_imag(g) + t * grid.unit_imag(h);
    const double length = std::sqrt(x * x + y * y);  // near 1: a chord of the unit circle
    x /= length;
    y /= length;
    bool converged = false;
    for (int step = 0; step < kMaxRootSteps; ++step) {
      double v_re = p_re[m], v_im = p_im[m], d_re = 0.0, d_im = 0.0;
      for (int j = m - 1; j >= 0; --j) {  // Horner for P and P'
        const double e_re = d_re * x - d_im * y + v_re;
        d_im = d_re * y + d_im * x + v_im;
        d_re = e_re;
        const double f_re = v_re * x - v_im * y + p_re[j];
        v_im = v_re * y + v_im * x + p_im[j];
        v_re = f_re;
      }
      const double denominator = d_re * d_re + d_im * d_im;
      if (!(denominator > 0.0)) break;
      const double dx = (v_re * d_re + v_im * d_im) / denominator;
      const double dy = (v_im * d_re - v_re * d_im) / denominator;
      x -= dx;
      y -= dy;
      if (dx * dx + dy * dy <= kRootTolerance * kRootTolerance) {
        converged = true;
        break;
      }
    }
    if (!converged) return false;
    const double radius = std::sqrt(x * x + y * y);
    if (!(std::abs(radius - 1.0) < kUnitCircleTolerance)) return false;
    // The root must be this bracket's: Newton may have gone to a neighbour's.
    const double phi = WrapPhase(std::atan2(y, x));
    const double middle = (g + 0.5) * spacing;
    double distance = std::abs(phi - middle);
    distance = std::min(distance, kTwoPi - distance);
    if (!(distance <= spacing)) return false;
    root_re[n] = x / radius;
    root_im[n] = y / radius;
    phases[n++] = phi;
  }
  if (n != m) return false;  // two roots within one grid step, or a degenerate lambda_min

  // 3. Weights: least squares against (c_0 - lambda_min, c_1, ..., c_m) (thesis alg. 8.2,
  // step 3) by the normal equations G w = r, G_lk = sum_j Re(e^{-i j phi_l} e^{i j phi_k}).
  double b_re[kMaxMoments], b_im[kMaxMoments];
  b_re[0] = c0 - lambda_min;
  b_im[0] = 0.0;
  for (int j = 1; j <= m; ++j) {
    b_re[j] = c[j].real();
    b_im[j] = c[j].imag();
  }
  Returns buffers[2];
  Returns* current = &buffers[0];
  Returns* trial_returns = &buffers[1];
  for (int l = 0; l < n; ++l) {
    current->phase[l] = phases[l];
    current->unit_re[l] = root_re[l];
    current->unit_im[l] = root_im[l];
  }
  SetPowers(m, n, current);
  double normal[4 * kMaxOrder * kMaxOrder];  // row-major, n x n then 2n x 2n
  double rhs[2 * kMaxOrder];                 // overwritten by the solution
  for (int l = 0; l < n; ++l) {
    for (int k = 0; k <= l; ++k) {
      double sum = 0.0;
      for (int j = 0; j <= m; ++j) {
        sum += current->re[l][j] * current->re[k][j] + current->im[l][j] * current->im[k][j];
      }
      normal[l * n + k] = sum;
    }
    double sum = 0.0;
    for (int j = 0; j <= m; ++j) sum += current->re[l][j] * b_re[j] + current->im[l][j] * b_im[j];
    rhs[l] = sum;
  }
  if (!SolveNormal(n, normal, rhs)) return false;
  for (int l = 0; l < n; ++l) current->weight[l] = rhs[l];
  SetResidual(m, n, b_re, b_im, current);

  // Gauss-Newton on phases and weights together, as PolishReturns of pisarenko.cc. The
  // Jacobian's columns are e^{i j phi_l} (for w_l) and i j w_l e^{i j phi_l} (for phi_l); with
  // S_p(l, k) = sum_j j^p e^{-i j phi_l} e^{i j phi_k}, J^T J has the blocks Re S_0(l, k),
  // -w_k Im S_1(l, k) and w_l w_k Re S_2(l, k), and J^T rho the entries Re sum_j e^{-i j phi_l}
  // rho_j and w_l Im sum_j j e^{-i j phi_l} rho_j.
  // The moment equations hold exactly for the decomposition (§8.4.1), so a residual at the
  // rounding level of c_0 leaves nothing to polish.
  const double converged_norm = (kPolishedResidual * c0) * (kPolishedResidual * c0);
  for (int step = 0; step < kPolishSteps && current->residual_norm > converged_norm; ++step) {
    const Returns& r = *current;
    const int size2 = 2 * n;
    for (int l = 0; l < n; ++l) {
      for (int k = 0; k < n; ++k) {
        double s0 = 0.0, s1 = 0.0, s2 = 0.0;
        for (int j = 0; j <= m; ++j) {
          const double real = r.re[l][j] * r.re[k][j] + r.im[l][j] * r.im[k][j];
          const double imag = r.re[l][j] * r.im[k][j] - r.im[l][j] * r.re[k][j];
          s0 += real;
          s1 += j * imag;
          s2 += j * j * real;
        }
        if (k <= l) {
          normal[l * size2 + k] = s0;
          normal[(n + l) * size2 + n + k] = r.weight[l] * r.weight[k] * s2;
        }
        normal[(n + k) * size2 + l] = -r.weight[k] * s1;  // row phi_k, column w_l
      }
      double g0 = 0.0, g1 = 0.0;
      for (int j = 0; j <= m; ++j) {
        g0 += r.re[l][j] * r.residual_re[j] + r.im[l][j] * r.residual_im[j];
        g1 += j * (r.re[l][j] * r.residual_im[j] - r.im[l][j] * r.residual_re[j]);
      }
      rhs[l] = -g0;
      rhs[n + l] = -r.weight[l] * g1;
    }
    if (!SolveNormal(size2, normal, rhs)) return false;
    for (int l = 0; l < n; ++l) {
      trial_returns->weight[l] = r.weight[l] + rhs[l];
      const double delta = rhs[n + l];
      trial_returns->phase[l] = WrapPhase(r.phase[l] + delta);
      // e^{i (phi + delta)} = e^{i phi} e^{i delta}; the polish's steps are small, where
      // Taylor's series to delta^6 is exact to rounding (|delta| < 1e-2: error < 1e-20).
      double cos_delta, sin_delta;
      if (std::abs(delta) < 1e-2) {
        const double d2 = delta * delta;
        cos_delta = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0)));
        sin_delta = delta * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0))));
      } else {
        cos_delta = std::cos(delta);
        sin_delta = std::sin(delta);
      }
      trial_returns->unit_re[l] = r.unit_re[l] * cos_delta - r.unit_im[l] * sin_delta;
      trial_returns->unit_im[l] = r.unit_re[l] * sin_delta + r.unit_im[l] * cos_delta;
    }
    SetPowers(m, n, trial_returns);
    SetResidual(m, n, b_re, b_im, trial_returns);
    if (!(trial_returns->residual_norm < r.residual_norm)) break;
    std::swap(current, trial_returns);
  }

  // Ascending phases, negligible returns dropped, as the reference.
  std::array<int, kMaxOrder> order;
  for (int l = 0; l < n; ++l) order[l] = l;
  std::sort(order.begin(), order.begin() + n,
            [&](int i, int j) { return current->phase[i] < current->phase[j]; });
  const double sparse_mass = std::max(c0 - lambda_min, 0.0);
  estimate->uniform = lambda_min;
  estimate->count = 0;
  for (int i = 0; i < n; ++i) {
    const int l = order[i];
    if (!(current->weight[l] > kNegligibleWeight * sparse_mass)) continue;
    estimate->phase[estimate->count] = current->phase[l];
    estimate->weight[estimate->count] = current->weight[l];
    ++estimate->count;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// The same route for eight pixels at a time, one SIMD lane each (kernels_simd.h), over chunks
// of pixels in three passes: lambda_min in lanes that take the next pixel as soon as theirs is
// found (LambdaMinChunk); the roots and weights vector by vector, a lane that has finished a
// loop masked out of it until the slowest has (FinishLanes); the polish for the lanes that
// need it, gathered into whole vectors (PolishQueued). Per lane are only the loading of a new
// pixel, the gathering of each bracket's grid values and the final sort. A lane that any step
// cannot vouch for (where PisarenkoByLevinson returns false) goes to the per-pixel path:
// PisarenkoByLevinson, then Pisarenko(). The arithmetic is PisarenkoByLevinson's but for the
// grid's halved sum and the roots' phases (below); the results differ from it by rounding
// (tests/reconstruct/kernels_test.cc holds both to the reference's contract).
namespace {

using simd::Abs;
using simd::Any;
using simd::Finite;
using simd::kLanes;
using simd::Select;
using simd::Splat;
using simd::Vd;
using simd::Vm;

#define TRANSIENT_LANE_INLINE __attribute__((always_inline)) inline

TRANSIENT_LANE_INLINE Vm None() { return Vm{} != Vm{}; }
TRANSIENT_LANE_INLINE Vd Max(Vd a, Vd b) { return Select(a < b, b, a); }  // std::max(a, b)
TRANSIENT_LANE_INLINE Vd Min(Vd a, Vd b) { return Select(b < a, b, a); }  // std::min(a, b)
// WrapPhase (moments.h) of a phase within one period of [0, 2 pi), as a root's phase or a
// polish step leaves it: 2 pi added or taken once (a tiny negative phase plus 2 pi that
// rounds to 2 pi becomes 0, as in WrapPhase).
TRANSIENT_LANE_INLINE Vd WrapPhaseNear(Vd phase) {
  const Vd period = Splat(kTwoPi);
  phase = Select(phase < Splat(0.0), phase + period, phase);
  return Select(phase >= period, phase - period, phase);
}

// SolveNormal() in every lane: `a` is n x n row-major (lower triangle read and overwritten),
// `b` becomes the solution. Returns the lanes whose pivots all pass kSmallestPivot and whose
// solution is finite.
template <int N>
TRANSIENT_LANE_INLINE Vm SolveNormalLanes(Vd* a, Vd* b) {
  Vd largest = a[0];
  for (int i = 1; i < N; ++i) largest = Max(largest, a[i * N + i]);
  const Vd one = Splat(1.0);
  const Vd smallest = Splat(kSmallestPivot) * largest;
  Vm ok = simd::True();
  Vd inverse[N];
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k <= i; ++k) {
      Vd sum = a[i * N + k];
      for (int j = 0; j < k; ++j) sum -= a[i * N + j] * a[k * N + j];
      if (k < i) {
        a[i * N + k] = sum * inverse[k];
      } else {
        ok &= sum > smallest;  // also NaN
        inverse[i] = one / simd::Sqrt(sum);
      }
    }
  }
  for (int i = 0; i < N; ++i) {
    Vd sum = b[i];
    for (int j = 0; j < i; ++j) sum -= a[i * N + j] * b[j];
    b[i] = sum * inverse[i];
  }
  for (int i = N - 1; i >= 0; --i) {
    Vd sum = b[i];
    for (int j = i + 1; j < N; ++j) sum -= a[j * N + i] * b[j];
    b[i] = sum * inverse[i];
  }
  for (int i = 0; i < N; ++i) ok &= Finite(b[i]);
  return ok;
}

// Returns in lanes: what `Returns` holds for one pixel, for M returns of order M.
template <int M>
struct ReturnLanes {
  Vd phase[M], unit_re[M], unit_im[M], weight[M];
  Vd re[M][M + 1], im[M][M + 1];
  Vd residual_re[M + 1], residual_im[M + 1];
  Vd residual_norm;

  TRANSIENT_LANE_INLINE void SetPowers() {
    for (int l = 0; l < M; ++l) {
      Vd pr = Splat(1.0), pi = Splat(0.0);
      for (int j = 0; j <= M; ++j) {
        re[l][j] = pr;
        im[l][j] = pi;
        const Vd next = pr * unit_re[l] - pi * unit_im[l];
        pi = pr * unit_im[l] + pi * unit_re[l];
        pr = next;
      }
    }
  }
  TRANSIENT_LANE_INLINE void SetResidual(const Vd* b_re, const Vd* b_im) {
    Vd norm = Splat(0.0);
    for (int j = 0; j <= M; ++j) {
      Vd x = -b_re[j], y = -b_im[j];
      for (int l = 0; l < M; ++l) {
        x += weight[l] * re[l][j];
        y += weight[l] * im[l][j];
      }
      residual_re[j] = x;
      residual_im[j] = y;
      norm += x * x + y * y;
    }
    residual_norm = norm;
  }
  // Takes `other`'s values in the lanes of `mask`.
  TRANSIENT_LANE_INLINE void Take(Vm mask, const ReturnLanes& other) {
    for (int l = 0; l < M; ++l) {
      phase[l] = Select(mask, other.phase[l], phase[l]);
      unit_re[l] = Select(mask, other.unit_re[l], unit_re[l]);
      unit_im[l] = Select(mask, other.unit_im[l], unit_im[l]);
      weight[l] = Select(mask, other.weight[l], weight[l]);
      for (int j = 0; j <= M; ++j) {
        re[l][j] = Select(mask, other.re[l][j], re[l][j]);
        im[l][j] = Select(mask, other.im[l][j], im[l][j]);
      }
    }
    for (int j = 0; j <= M; ++j) {
      residual_re[j] = Select(mask, other.residual_re[j], residual_re[j]);
      residual_im[j] = Select(mask, other.residual_im[j], residual_im[j]);
    }
    residual_norm = Select(mask, other.residual_norm, residual_norm);
  }
};

// Step 1's results for a chunk of pixels, one slot a pixel.
template <int M>
struct LambdaChunk {
  static constexpr int kSize = 256;
  alignas(64) double q_re[M + 1][kSize];
  alignas(64) double q_im[M + 1][kSize];
  alignas(64) double lambda_min[kSize];
  alignas(64) int64_t ok[kSize];  // -1 where step 1 found lambda_min, else 0
};

// Step 1 of PisarenkoByLevinson (lambda_min, and q at it) for pixels [begin, begin + count),
// count <= LambdaChunk::kSize, in lanes that take the next pixel as soon as theirs is done:
// pixels need 2 to 20 recursions, and a vector that waited for its slowest lane would run
// 11.3 turns for the 7.2 that its pixels need on average (m = 3, the benchmark's frames). Each
// turn runs the recursion at every lane's next shift, then moves each lane on by its outcome:
// - a new pixel's first recursion (at 0) starts its Newton steps, or, beyond the leading
//   minor's lambda_min, restarts from Gershgorin's bound (PisarenkoByLevinson's `restart`);
// - then the loop's turn: the bracket, Newton's step, convergence, the next shift.
// A lane that finishes (or fails) writes its slot and takes the next pixel.
template <int M>
TRANSIENT_LANE_INLINE void LambdaMinChunk(const SolvedImage& solved, int64_t begin, int count,
                                          LambdaChunk<M>* out) {
  const int64_t pixels = solved.geometry.pixel_count();
  const Vd zero = Splat(0.0);
  const Vd infinity = Splat(std::numeric_limits<double>::infinity());
  for (int o = 0; o < count; ++o) out->ok[o] = 0;
  // The next pixel whose C(c) the route can take (PisarenkoByLevinson's first checks), or -1.
  int queue = 0;
  const auto next_pixel = [&]() {
    for (; queue < count; ++queue) {
      const int64_t pixel = begin + queue;
      if (!solved.valid(pixel)) continue;
      const double c0 = solved.c_real[pixel];
      if (!(c0 > 0.0) || !std::isfinite(c0)) continue;
      bool finite = true;
      for (int j = 1; j <= M; ++j) {
        finite &= std::isfinite(solved.c_real[j * pixels + pixel]) &&
                  std::isfinite(solved.c_imag[j * pixels + pixel]);
      }
      if (finite) return queue++;
    }
    return -1;
  };
  Vd cr[M + 1], ci[M + 1], qr[M + 1], qi[M + 1], tr[M + 1], ti[M + 1];
  for (int j = 0; j <= M; ++j) cr[j] = ci[j] = qr[j] = qi[j] = zero;
  Vd below = zero, above = zero, lambda = zero, next = zero, tolerance = zero, lambda_min = zero;
  Vd steps = zero;
  Vm live = None(), start = None(), restart = None(), positive = None();
  int slot[kLanes] = {};
  // Puts pixels into the lanes of `lanes` that have none, and starts them.
  const auto refill = [&](Vm lanes) {
    Vm fresh = None();
    for (int i = 0; i < kLanes; ++i) {
      if (lanes[i] == 0) continue;
      const int o = next_pixel();
      if (o < 0) {
        live[i] = 0;
        continue;
      }
      const int64_t pixel = begin + o;
      for (int j = 0; j <= M; ++j) {
        cr[j][i] = solved.c_real[j * pixels + pixel];
        ci[j][i] = j == 0 ? 0.0 : solved.c_imag[j * pixels + pixel];
      }
      slot[i] = o;
      live[i] = -1;
      fresh[i] = -1;
    }
    below = Select(fresh, -infinity, below);
    above = Select(fresh, cr[0], above);  // lambda_min <= e_0^* C e_0 = c_0
    lambda = Select(fresh, zero, lambda);
    next = Select(fresh, zero, next);
    tolerance = Select(fresh, Splat(kLambdaTolerance) * cr[0], tolerance);
    steps = Select(fresh, zero, steps);
    start |= fresh;
    restart &= ~fresh;
  };
  refill(simd::True());
  while (Any(live)) {
    Vm indefinite;
    const Vm fine = simd::LevinsonLanes<M, true>(cr[0] - next, cr, ci, tr, ti, &indefinite);
    const Vm definite = fine & ~indefinite;
    const Vm stepping_before = live & ~start & ~restart;
    Vm done = None(), found = None();
    // A new pixel beyond the leading minor's lambda_min restarts below lambda_min.
    const Vm to_restart = live & start & ~fine;
    done |= live & restart & ~definite;  // not even there: the per-pixel path
    const Vm failed = stepping_before & ~fine;
    const Vm singular = failed & (next < lambda);  // from above: singular to rounding
    lambda_min = Select(singular, next, lambda_min);
    done |= singular;
    found |= singular;
    above = Select(failed & ~singular, next, above);  // past the leading minor's: bisect
    const Vm accepted = live & ((start & fine) | (restart & definite) | (stepping_before & fine));
    lambda = Select(accepted, next, lambda);
    positive = (accepted & definite) | (~accepted & positive);
    for (int j = 0; j <= M; ++j) {
      qr[j] = Select(accepted, tr[j], qr[j]);
      qi[j] = Select(accepted, ti[j], qi[j]);
    }
    if (Any(to_restart)) {  // from Gershgorin's bound on lambda_min
      Vd off_diagonal = zero;
      for (int j = 1; j <= M; ++j) {
        off_diagonal += Splat(2.0) * simd::Sqrt(cr[j] * cr[j] + ci[j] * ci[j]);
      }
      above = Select(to_restart, lambda, above);
      next = Select(to_restart, cr[0] - off_diagonal - Splat(1e-9) * cr[0], next);
    }
    restart = to_restart;
    start = None();
    // The loop's turn (PisarenkoByLevinson's step 1) for the lanes in it.
    const Vm stepping = live & ~done & ~to_restart;
    steps = Select(stepping, steps + Splat(1.0), steps);
    done |= stepping & (steps > Splat(kMaxLambdaSteps));  // no convergence
    below = Select(stepping & positive, Max(below, lambda), below);
    above = Select(stepping & ~positive, Min(above, lambda), above);
    Vd norm = zero;
    for (int j = 0; j <= M; ++j) norm += qr[j] * qr[j] + qi[j] * qi[j];
    const Vd newton = qr[0] / norm;
    const Vm converged = stepping & ~done & (Abs(newton) <= tolerance);
    lambda_min = Select(converged, lambda + newton, lambda_min);
    const Vd step_to = lambda + newton;
    const Vm inside = (step_to > below) & (step_to < above);
    const Vm collapsed = stepping & ~done & ~converged & ~inside & ~(above - below > tolerance);
    lambda_min = Select(collapsed, Splat(0.5) * (below + above), lambda_min);
    done |= converged | collapsed;
    found |= converged | collapsed;
    next = Select(stepping & ~done,
                  Select(inside, step_to,
                         Select(Finite(below), Splat(0.5) * (below + above),
                                above - Splat(2.0) * (above - lambda))),
                  next);
    if (!Any(done)) continue;
    for (int i = 0; i < kLanes; ++i) {
      if (done[i] == 0) continue;
      const int o = slot[i];
      out->ok[o] = found[i] != 0 && std::isfinite(lambda_min[i]) ? -1 : 0;
      out->lambda_min[o] = lambda_min[i];
      for (int j = 0; j <= M; ++j) {
        out->q_re[j][o] = qr[j][i];
        out->q_im[j][o] = qi[j][i];
      }
    }
    refill(done);
  }
}

// The Gauss-Newton polish of PisarenkoByLevinson in lanes, while the lanes of `polishing`
// still improve; clears from *ok the lanes whose normal matrix it could not factorise.
template <int M>
TRANSIENT_LANE_INLINE void PolishLanes(Vm polishing, const Vd* b_re, const Vd* b_im,
                                       Vd converged_norm, ReturnLanes<M>* current,
                                       ReturnLanes<M>* trial, Vm* ok_lanes) {
  const Vd zero = Splat(0.0), one = Splat(1.0);
  Vm& ok = *ok_lanes;
  Vd normal[4 * M * M];
  Vd rhs[2 * M];
  for (int step = 0; step < kPolishSteps; ++step) {
    const Vm active_polish = polishing & (current->residual_norm > converged_norm);
    if (!Any(active_polish)) break;
    const ReturnLanes<M>& r = *current;
    constexpr int kSize2 = 2 * M;
    for (int l = 0; l < M; ++l) {
      for (int k = 0; k < M; ++k) {
        Vd s0 = zero, s1 = zero, s2 = zero;
        for (int j = 0; j <= M; ++j) {
          const Vd real = r.re[l][j] * r.re[k][j] + r.im[l][j] * r.im[k][j];
          const Vd imag = r.re[l][j] * r.im[k][j] - r.im[l][j] * r.re[k][j];
          s0 += real;
          s1 += static_cast<double>(j) * imag;
          s2 += static_cast<double>(j * j) * real;
        }
        if (k <= l) {
          normal[l * kSize2 + k] = s0;
          normal[(M + l) * kSize2 + M + k] = r.weight[l] * r.weight[k] * s2;
        }
        normal[(M + k) * kSize2 + l] = -r.weight[k] * s1;
      }
      Vd g0 = zero, g1 = zero;
      for (int j = 0; j <= M; ++j) {
        g0 += r.re[l][j] * r.residual_re[j] + r.im[l][j] * r.residual_im[j];
        g1 += static_cast<double>(j) *
              (r.re[l][j] * r.residual_im[j] - r.im[l][j] * r.residual_re[j]);
      }
      rhs[l] = -g0;
      rhs[M + l] = -r.weight[l] * g1;
    }
    const Vm solvable = SolveNormalLanes<kSize2>(normal, rhs);
    ok &= ~active_polish | solvable;
    const Vm stepping = active_polish & solvable;
    for (int l = 0; l < M; ++l) {
      trial->weight[l] = r.weight[l] + rhs[l];
      const Vd delta = rhs[M + l];
      // WrapPhase for the small steps of a polish, lane by lane beyond them.
      Vd phase = WrapPhaseNear(r.phase[l] + delta);
      // As PisarenkoByLevinson: Taylor's series to delta^6 below 1e-2, cos and sin above.
      const Vd d2 = delta * delta;
      Vd cos_delta = one - d2 * (Splat(0.5) - d2 * (Splat(1.0 / 24.0) - d2 * Splat(1.0 / 720.0)));
      Vd sin_delta =
          delta *
          (one - d2 * (Splat(1.0 / 6.0) - d2 * (Splat(1.0 / 120.0) - d2 * Splat(1.0 / 5040.0))));
      const Vm large = stepping & ~(Abs(delta) < Splat(1e-2));
      if (Any(large)) {
        for (int i = 0; i < kLanes; ++i) {
          if (large[i] == 0) continue;
          cos_delta[i] = std::cos(delta[i]);
          sin_delta[i] = std::sin(delta[i]);
          phase[i] = WrapPhase(r.phase[l][i] + delta[i]);
        }
      }
      trial->phase[l] = phase;
      trial->unit_re[l] = r.unit_re[l] * cos_delta - r.unit_im[l] * sin_delta;
      trial->unit_im[l] = r.unit_re[l] * sin_delta + r.unit_im[l] * cos_delta;
    }
    trial->SetPowers();
    trial->SetResidual(b_re, b_im);
    const Vm improved = stepping & (trial->residual_norm < r.residual_norm);
    current->Take(improved, *trial);
    polishing = improved;
  }
}

// Writes the returns of the lanes of `ok`, lane i to pixel lane_pixels[i]: ascending phases,
// negligible returns dropped, as PisarenkoByLevinson.
template <int M>
TRANSIENT_LANE_INLINE void WriteLanes(const ReturnLanes<M>& r, Vd lambda_min, Vd c0, Vm ok,
                                      const int64_t* lane_pixels, int64_t pixels,
                                      PisarenkoImage* result, int64_t* decided) {
  const Vd sparse_mass = Max(c0 - lambda_min, Splat(0.0));
  for (int i = 0; i < kLanes; ++i) {
    if (ok[i] == 0) continue;
    const int64_t pixel = lane_pixels[i];
    std::array<int, M> order;
    for (int l = 0; l < M; ++l) order[l] = l;
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return r.phase[a][i] < r.phase[b][i]; });
    result->uniform[pixel] = static_cast<float>(lambda_min[i]);
    int count = 0;
    for (int l : order) {
      const double weight = r.weight[l][i];
      if (!(weight > kNegligibleWeight * sparse_mass[i])) continue;
      result->phase[count * pixels + pixel] = static_cast<float>(r.phase[l][i]);
      result->weight[count * pixels + pixel] = static_cast<float>(weight);
      ++count;
    }
    ++*decided;
  }
}

// The returns of a chunk's pixels that need the polish, gathered from FinishLanes's vectors
// into whole vectors of their own (PolishQueued).
template <int M>
struct PolishQueue {
  static constexpr int kSize = LambdaChunk<M>::kSize;
  int count = 0;
  int64_t pixel[kSize + kLanes];
  alignas(64) double phase[M][kSize + kLanes];
  alignas(64) double unit_re[M][kSize + kLanes];
  alignas(64) double unit_im[M][kSize + kLanes];
  alignas(64) double weight[M][kSize + kLanes];
  alignas(64) double b_re[M + 1][kSize + kLanes];
  alignas(64) double b_im[M + 1][kSize + kLanes];
  alignas(64) double c0[kSize + kLanes];
  alignas(64) double lambda_min[kSize + kLanes];

  TRANSIENT_LANE_INLINE void Push(Vm lanes, const ReturnLanes<M>& r, const Vd* b_re_lanes,
                                  const Vd* b_im_lanes, Vd c0_lanes, Vd lambda_min_lanes,
                                  int64_t p) {
    for (int i = 0; i < kLanes; ++i) {
      if (lanes[i] == 0) continue;
      Copy(count++, i, r, b_re_lanes, b_im_lanes, c0_lanes, lambda_min_lanes, p + i);
    }
  }
  TRANSIENT_LANE_INLINE void Copy(int k, int i, const ReturnLanes<M>& r, const Vd* b_re_lanes,
                                  const Vd* b_im_lanes, Vd c0_lanes, Vd lambda_min_lanes,
                                  int64_t at) {
    pixel[k] = at;
    for (int l = 0; l < M; ++l) {
      phase[l][k] = r.phase[l][i];
      unit_re[l][k] = r.unit_re[l][i];
      unit_im[l][k] = r.unit_im[l][i];
      weight[l][k] = r.weight[l][i];
    }
    for (int j = 0; j <= M; ++j) {
      b_re[j][k] = b_re_lanes[j][i];
      b_im[j][k] = b_im_lanes[j][i];
    }
    c0[k] = c0_lanes[i];
    lambda_min[k] = lambda_min_lanes[i];
  }
  // Entries count.. up to the next whole vector repeat the last one (whose lanes are masked).
  TRANSIENT_LANE_INLINE void Pad() {
    for (int k = count; k % kLanes != 0; ++k) {
      pixel[k] = pixel[count - 1];
      for (int l = 0; l < M; ++l) {
        phase[l][k] = phase[l][count - 1];
        unit_re[l][k] = unit_re[l][count - 1];
        unit_im[l][k] = unit_im[l][count - 1];
        weight[l][k] = weight[l][count - 1];
      }
      for (int j = 0; j <= M; ++j) {
        b_re[j][k] = b_re[j][count - 1];
        b_im[j][k] = b_im[j][count - 1];
      }
      c0[k] = c0[count - 1];
      lambda_min[k] = lambda_min[count - 1];
    }
  }
};

// Steps 2 and 3 of PisarenkoByLevinson for pixels [p, p + kLanes), after step 1 in `chunk`
// from slot o; *decided counts the lanes settled here, the others (valid ones) go to the
// per-pixel path.
template <int M>
TRANSIENT_LANE_INLINE void FinishLanes(const SolvedImage& solved, const PisarenkoSearchGrid& grid,
                                       const LambdaChunk<M>& chunk, int o, int64_t p,
                                       PolishQueue<M>* polish, PisarenkoImage* result,
                                       int64_t* decided) {
  constexpr int kPoints = 16 * (M + 1);
  const int64_t pixels = solved.geometry.pixel_count();
  const Vd zero = Splat(0.0), one = Splat(1.0);
  Vm valid;
  for (int i = 0; i < kLanes; ++i) valid[i] = solved.valid(p + i) ? -1 : 0;
  Vm ok;
  std::memcpy(&ok, chunk.ok + o, sizeof(ok));
  Vd cr[M + 1], ci[M + 1], qr[M + 1], qi[M + 1];
  for (int j = 0; j <= M; ++j) {
    // Lanes without a lambda_min get the identity (c = e_0): no NaN runs through the others'.
    cr[j] = Select(ok, simd::Load(solved.c_real.data() + j * pixels + p), Splat(j == 0));
    ci[j] = j == 0 ? zero : Select(ok, simd::Load(solved.c_imag.data() + j * pixels + p), zero);
    qr[j] = Select(ok, simd::Load(chunk.q_re[j] + o), Splat(j == 0));
    qi[j] = Select(ok, simd::Load(chunk.q_im[j] + o), zero);
  }
  const Vd c0 = cr[0];
  const Vd lambda_min = Select(ok, simd::Load(chunk.lambda_min + o), zero);

  // 2. The roots on the unit circle (PisarenkoByLevinson's step 2).
  const Vd q0 = Abs(qr[0]);
  const Vd persymmetry = (qr[M] * qr[M] + qi[M] * qi[M]) / (q0 * q0) - one;
  ok &= Abs(persymmetry) < Splat(2.0 * kPersymmetryTolerance);
  if (!Any(ok)) goto per_pixel;
  {
    // e^{i theta / 2} = sqrt(q_m / q_0) (q_0 is real): the principal square root, (s, y / 2s)
    // with s = sqrt((r + x) / 2) for x >= 0, else (|y| / 2t, sign(y) t), t = sqrt((r - x) / 2);
    // |q_m / q_0| is 1 here, so neither s nor t is small.
    const Vd zr = qr[M] / qr[0], zi = qi[M] / qr[0];
    const Vd r = simd::Sqrt(zr * zr + zi * zi);
    const Vm right_half = zr >= zero;
    const Vd s = simd::Sqrt(Splat(0.5) * (r + Abs(zr)));
    const Vd t = Splat(0.5) * Abs(zi) / s;
    const Vd signed_s = Select(zi < zero, -s, s);
    const Vd rotation_re = Select(right_half, s, t);
    const Vd rotation_im = Select(right_half, Splat(0.5) * zi / s, signed_s);
    const Vd inverse_q0 = one / q0;
    Vd p_re[M + 1], p_im[M + 1], a_re[M + 1], a_im[M + 1];
    for (int j = 0; j <= M; ++j) {
      p_re[j] = qr[j] * inverse_q0;
      p_im[j] = -qi[j] * inverse_q0;
      a_re[j] = rotation_re * p_re[j] - rotation_im * p_im[j];
      a_im[j] = rotation_re * p_im[j] + rotation_im * p_re[j];
    }
    // R(phi) = sum_j Re(a_j w_j), w_j = e^{i (j - m/2) phi}, and w_{m-j} = conj(w_j), where
    // Re(a_{m-j} conj(w_j)) = Re(conj(a_{m-j}) w_j): the terms j and m - j are one,
    // Re((a_j + conj(a_{m-j})) w_j), and the middle one of an even m is Re a_{m/2}. Half of
    // PisarenkoByLevinson's products, the same function.
    constexpr int kPairs = (M + 1) / 2;
    Vd pair_re[kPairs], pair_im[kPairs];
    for (int j = 0; j < kPairs; ++j) {
      pair_re[j] = a_re[j] + a_re[M - j];
      pair_im[j] = a_im[j] - a_im[M - j];
    }
    const Vd middle_term = M % 2 == 0 ? a_re[M / 2] : zero;
    Vd values[kPoints];
    for (int g = 0; g < kPoints; ++g) {
      Vd v = middle_term;
      for (int j = 0; j < kPairs; ++j) {
        v += pair_re[j] * grid.real(j)[g] - pair_im[j] * grid.imag(j)[g];
      }
      values[g] = v;
    }
    // Brackets: the sign changes of R, exactly M of them in each lane, recorded as the grid
    // index g of each (slot l takes the l-th), then Newton's starting point in each: the chord
    // point between the grid's two points put back on the circle.
    const double spacing = kTwoPi / kPoints;
    Vd slot[M];
    for (int l = 0; l < M; ++l) slot[l] = zero;
    Vm count = Vm{};
    Vm negative = values[0] < zero;
    // R(phi + 2 pi) = (-1)^m R(phi): after the last point comes -R(0) for odd m.
    const Vd last = (M % 2 == 0) ? values[0] : -values[0];
    for (int g = 0; g < kPoints; ++g) {
      const Vm next_negative = (g + 1 < kPoints ? values[g + 1] : last) < zero;
      const Vm change = negative ^ next_negative;
      for (int l = 0; l < M; ++l)
        slot[l] = Select(change & (count == (Vm{} + l)), Splat(g), slot[l]);
      count -= change;  // a set lane of a comparison is -1
      negative = next_negative;
    }
    ok &= count == (Vm{} + M);  // more sign changes than roots: rounding at a double root
    Vd x[M], y[M], middle_re[M], middle_im[M], middle[M];
    for (int l = 0; l < M; ++l) {
      Vd left = one, right = -one, gx = one, gy = zero, hx = one, hy = zero;
      for (int i = 0; i < kLanes; ++i) {
        if (ok[i] == 0) continue;
        const int g = static_cast<int>(slot[l][i]);
        const int h = (g + 1) % kPoints;
        left[i] = values[g][i];
        right[i] = g + 1 < kPoints ? values[g + 1][i] : last[i];
        gx[i] = grid.unit_real(g);
        gy[i] = grid.unit_imag(g);
        hx[i] = grid.unit_real(h);
        hy[i] = grid.unit_imag(h);
      }
      const Vd t = left / (left - right);
      const Vd cx = (one - t) * gx + t * hx;
      const Vd cy = (one - t) * gy + t * hy;
      const Vd length = simd::Sqrt(cx * cx + cy * cy);  // near 1: a chord of the unit circle
      x[l] = cx / length;
      y[l] = cy / length;
      // The bracket's middle, e^{i (g + 1/2) spacing}, bisecting its two grid points.
      const Vd mx = gx + hx, my = gy + hy;
      const Vd middle_length = simd::Sqrt(mx * mx + my * my);
      middle_re[l] = mx / middle_length;
      middle_im[l] = my / middle_length;
      middle[l] = (slot[l] + Splat(0.5)) * Splat(spacing);
    }
    // Newton's method on P for all M roots of all lanes together.
    Vm searching[M], found[M];
    for (int l = 0; l < M; ++l) {
      searching[l] = ok;
      found[l] = None();
    }
    const Vd tolerance_squared = Splat(kRootTolerance * kRootTolerance);
    for (int step = 0; step < kMaxRootSteps; ++step) {
      Vm any = None();
      for (int l = 0; l < M; ++l) any |= searching[l];
      if (!Any(any)) break;
      for (int l = 0; l < M; ++l) {
        Vd v_re = p_re[M], v_im = p_im[M], d_re = zero, d_im = zero;
        for (int j = M - 1; j >= 0; --j) {  // Horner for P and P'
          const Vd e_re = d_re * x[l] - d_im * y[l] + v_re;
          d_im = d_re * y[l] + d_im * x[l] + v_im;
          d_re = e_re;
          const Vd f_re = v_re * x[l] - v_im * y[l] + p_re[j];
          v_im = v_re * y[l] + v_im * x[l] + p_im[j];
          v_re = f_re;
        }
        const Vd denominator = d_re * d_re + d_im * d_im;
        searching[l] &= denominator > zero;  // a lane that stops here has not converged
        const Vd dx = (v_re * d_re + v_im * d_im) / denominator;
        const Vd dy = (v_im * d_re - v_re * d_im) / denominator;
        x[l] = Select(searching[l], x[l] - dx, x[l]);
        y[l] = Select(searching[l], y[l] - dy, y[l]);
        const Vm converged = searching[l] & (dx * dx + dy * dy <= tolerance_squared);
        found[l] |= converged;
        searching[l] &= ~converged;
      }
    }
    ReturnLanes<M> returns;
    ReturnLanes<M>* current = &returns;
    for (int l = 0; l < M; ++l) {
      ok &= found[l];
      const Vd radius = simd::Sqrt(x[l] * x[l] + y[l] * y[l]);
      ok &= Abs(radius - one) < Splat(kUnitCircleTolerance);
      current->unit_re[l] = x[l] / radius;
      current->unit_im[l] = y[l] / radius;
    }
    // Each root in its own bracket (Newton may have gone to a neighbour's): within one grid
    // step of the bracket's middle, whose phase is known, so that the root's phase is the
    // middle's plus the small angle delta between them, tan delta = cross / dot:
    // atan t = sum_k (-1)^k t^(2k+1) / (2k+1), |t| <= tan(2 pi / 32) < 0.2, where 13 terms
    // leave an error below 0.2^27 / 27 < 1e-20 (an alternating series: less than the first
    // term left out). PisarenkoByLevinson takes atan2 of the root instead (one ulp apart).
    const Vd largest_tangent = Splat(std::tan(spacing));
    for (int l = 0; l < M; ++l) {
      const Vd ux = current->unit_re[l], uy = current->unit_im[l];
      const Vd dot = middle_re[l] * ux + middle_im[l] * uy;
      const Vd cross = middle_re[l] * uy - middle_im[l] * ux;
      const Vd t = cross / dot;
      ok &= (dot > zero) & (Abs(t) <= largest_tangent);
      const Vd t2 = t * t;
      Vd series = Splat(1.0 / 25.0);
      for (int k = 11; k >= 0; --k) {
        series = Splat((k % 2 == 0 ? 1.0 : -1.0) / (2 * k + 1)) + t2 * series;
      }
      current->phase[l] = WrapPhaseNear(middle[l] + t * series);
    }
    if (!Any(ok)) goto per_pixel;

    // 3. Weights by the normal equations, then the Gauss-Newton polish (step 3 above).
    Vd b_re[M + 1], b_im[M + 1];
    b_re[0] = c0 - lambda_min;
    b_im[0] = zero;
    for (int j = 1; j <= M; ++j) {
      b_re[j] = cr[j];
      b_im[j] = ci[j];
    }
    current->SetPowers();
    Vd normal[4 * M * M];
    Vd rhs[2 * M];
    for (int l = 0; l < M; ++l) {
      for (int k = 0; k <= l; ++k) {
        Vd sum = zero;
        for (int j = 0; j <= M; ++j) {
          sum += current->re[l][j] * current->re[k][j] + current->im[l][j] * current->im[k][j];
        }
        normal[l * M + k] = sum;
      }
      Vd sum = zero;
      for (int j = 0; j <= M; ++j) sum += current->re[l][j] * b_re[j] + current->im[l][j] * b_im[j];
      rhs[l] = sum;
    }
    ok &= SolveNormalLanes<M>(normal, rhs);
    for (int l = 0; l < M; ++l) current->weight[l] = rhs[l];
    current->SetResidual(b_re, b_im);
    // The lanes whose moment equations do not hold to kPolishedResidual yet wait in `polish`
    // for a vector of their own (a fifth of the lanes at m = 3 on the benchmark's frames, but
    // in most vectors); the others are done.
    const Vd converged_norm = (Splat(kPolishedResidual) * c0) * (Splat(kPolishedResidual) * c0);
    const Vm unpolished = ok & (current->residual_norm > converged_norm);
    if (Any(unpolished)) polish->Push(unpolished, *current, b_re, b_im, c0, lambda_min, p);
    ok &= ~unpolished;
    int64_t lane_pixels[kLanes];
    for (int i = 0; i < kLanes; ++i) lane_pixels[i] = p + i;
    WriteLanes<M>(*current, lambda_min, c0, ok, lane_pixels, pixels, result, decided);
    ok |= unpolished;  // not for the per-pixel path below
  }
per_pixel:
  for (int i = 0; i < kLanes; ++i) {
    if (valid[i] != 0 && ok[i] == 0) {
      internal::PisarenkoPixels(solved, p + i, p + i + 1, result, &grid);
    }
  }
}

// Polishes and writes the queued returns, a whole vector at a time; a lane the polish cannot
// vouch for goes to the per-pixel path.
template <int M>
TRANSIENT_LANE_INLINE void PolishQueued(const SolvedImage& solved, const PisarenkoSearchGrid& grid,
                                        PolishQueue<M>* queue, PisarenkoImage* result,
                                        int64_t* decided) {
  if (queue->count == 0) return;
  queue->Pad();
  const int64_t pixels = solved.geometry.pixel_count();
  for (int k = 0; k < queue->count; k += kLanes) {
    Vm ok;
    for (int i = 0; i < kLanes; ++i) ok[i] = k + i < queue->count ? -1 : 0;
    ReturnLanes<M> buffers[2];
    ReturnLanes<M>* current = &buffers[0];
    for (int l = 0; l < M; ++l) {
      current->phase[l] = simd::Load(queue->phase[l] + k);
      current->unit_re[l] = simd::Load(queue->unit_re[l] + k);
      current->unit_im[l] = simd::Load(queue->unit_im[l] + k);
      current->weight[l] = simd::Load(queue->weight[l] + k);
    }
    Vd b_re[M + 1], b_im[M + 1];
    for (int j = 0; j <= M; ++j) {
      b_re[j] = simd::Load(queue->b_re[j] + k);
      b_im[j] = simd::Load(queue->b_im[j] + k);
    }
    const Vd c0 = simd::Load(queue->c0 + k);
    const Vd lambda_min = simd::Load(queue->lambda_min + k);
    current->SetPowers();
    current->SetResidual(b_re, b_im);
    const Vd converged_norm = (Splat(kPolishedResidual) * c0) * (Splat(kPolishedResidual) * c0);
    const Vm in_queue = ok;
    PolishLanes<M>(ok, b_re, b_im, converged_norm, current, &buffers[1], &ok);
    WriteLanes<M>(*current, lambda_min, c0, ok, queue->pixel + k, pixels, result, decided);
    for (int i = 0; i < kLanes; ++i) {
      if (in_queue[i] != 0 && ok[i] == 0) {
        internal::PisarenkoPixels(solved, queue->pixel[k + i], queue->pixel[k + i] + 1, result,
                                  &grid);
      }
    }
  }
}

// Pixels [p, end) of order M, whole vectors of them in chunks: step 1 for the chunk, then steps 2
// and 3 vector by vector, then the polish for the lanes that need it. Returns the first pixel
// left, fewer than a vector before `end`.
template <int M>
TRANSIENT_LANE_INLINE int64_t PisarenkoChunks(const SolvedImage& solved,
                                              const PisarenkoSearchGrid& grid, int64_t p,
                                              int64_t end, PisarenkoImage* result,
                                              int64_t* decided) {
  while (p + kLanes <= end) {
    LambdaChunk<M> chunk;
    const int count =
        static_cast<int>(std::min<int64_t>(LambdaChunk<M>::kSize, (end - p) / kLanes * kLanes));
    LambdaMinChunk<M>(solved, p, count, &chunk);
    PolishQueue<M> polish;
    for (int o = 0; o < count; o += kLanes) {
      FinishLanes<M>(solved, grid, chunk, o, p + o, &polish, result, decided);
    }
    PolishQueued<M>(solved, grid, &polish, result, decided);
    p += count;
  }
  return p;
}

TRANSIENT_LANE_INLINE void PisarenkoBlockAnyOrder(const SolvedImage& solved,
                                                  const PisarenkoSearchGrid& grid, int64_t begin,
                                                  int64_t end, PisarenkoImage* result,
                                                  int64_t* decided) {
  int64_t p = begin;
  // Orders up to 8 in lanes (each order compiled costs compile time, ~9 s of Clang under the
  // sanitizers); above, per pixel. Whole vectors only; the last pixels of the range, fewer than
  // a vector, per pixel. Under the sanitizers, where compile time counts and speed does not,
  // only the orders the kernel tests run (1, 3, 4 and 8): the others are the same template.
  switch (solved.order) {
#define TRANSIENT_PISARENKO_CASE(M)                                \
  case M:                                                          \
    p = PisarenkoChunks<M>(solved, grid, p, end, result, decided); \
    break;
    TRANSIENT_PISARENKO_CASE(1)
    TRANSIENT_PISARENKO_CASE(3)
    TRANSIENT_PISARENKO_CASE(4)
    TRANSIENT_PISARENKO_CASE(8)
#if !defined(TRANSIENT_SIMD_BASELINE_ONLY)
    TRANSIENT_PISARENKO_CASE(2)
    TRANSIENT_PISARENKO_CASE(5)
    TRANSIENT_PISARENKO_CASE(6)
    TRANSIENT_PISARENKO_CASE(7)
#endif
#undef TRANSIENT_PISARENKO_CASE
    default:
      break;
  }
  internal::PisarenkoPixels(solved, p, end, result, &grid);
}

TRANSIENT_SIMD_VARIANTS(PisarenkoBlockLanes, PisarenkoBlockAnyOrder,
                        (const SolvedImage& solved, const PisarenkoSearchGrid& grid, int64_t begin,
                         int64_t end, PisarenkoImage* result, int64_t* decided),
                        (solved, grid, begin, end, result, decided))

#undef TRANSIENT_LANE_INLINE

}  // namespace

namespace internal {

int64_t PisarenkoBlock(const SolvedImage& solved, const PisarenkoSearchGrid& grid, int64_t begin,
                       int64_t end, PisarenkoImage* result) {
  int64_t decided = 0;
  PisarenkoBlockLanes(solved, grid, begin, end, result, &decided);
  return decided;
}

}  // namespace internal

}  // namespace transient

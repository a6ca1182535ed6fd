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
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>

#include "kernels_internal.h"
#include "kernels_simd.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/pisarenko.h"
#include "transient/reconstruct/polynomial.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient {
namespace {

constexpr int kMaxRootSteps = 30;
constexpr double kRootTolerance = 1e-13;  // |Newton step| on P
// A root of the eigenvector's polynomial this far from the unit circle means lambda_min was
// not found (the reference drops such roots as spurious; here the pixel goes to it).
constexpr double kUnitCircleTolerance = 1e-6;
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

  // 1. lambda_min (header comment): Newton's steps on f = 1 / q_0 within the bracket of
  // iterates known below and above it (ToeplitzLambdaMin, levinson.cc).
  std::array<Complex, kMaxMoments> q_storage;
  const std::span<Complex> q(q_storage.data(), size);
  double lambda_min = 0.0;
  if (!ToeplitzLambdaMin(c, &lambda_min, q)) return false;

  // 2. The roots on the unit circle. Normalised by q_0 so that the eigenvector is O(1).
  // q_0 is real (Levinson); |q_m| / |q_0| compared squared (q is O(1/distance), no overflow).
  if (!LooksLikeLambdaMinEigenvector(q)) return false;
  const double q0 = std::abs(q[0].real());
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
      const PolynomialAndDerivative at = EvaluateWithDerivative(p_re, p_im, m, x, y);
      const double v_re = at.re, v_im = at.im, d_re = at.d_re, d_im = at.d_im;
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
// The same route for eight or four pixels at a time, one SIMD lane each (kernels_simd.h), over
// chunks of pixels in three passes: lambda_min in lanes that take the next pixel as soon as theirs
// is found (LambdaMinChunk); the roots and weights vector by vector, a lane that has finished a
// loop masked out of it until the slowest has (FinishLanes); the polish for the lanes that
// need it, gathered into whole vectors (PolishQueued). Per lane are only the loading of a new
// pixel, the gathering of each bracket's grid values and the final sort. A lane that any step
// cannot vouch for (where PisarenkoByLevinson returns false) goes to the per-pixel path:
// PisarenkoByLevinson, then Pisarenko(). The arithmetic is PisarenkoByLevinson's but for the
// grid's halved sum and the roots' phases (below); the results differ from it by rounding
// (tests/reconstruct/kernels_test.cc holds both to the reference's contract).
namespace {

#define TRANSIENT_LANE_INLINE __attribute__((always_inline)) inline

// The lane code for each lane count (kernels_simd.h).
#define TRANSIENT_LANE_CODE "optimized_pisarenko_lanes.inc"
#include "simd_namespaces.inc"

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

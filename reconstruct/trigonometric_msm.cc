// Trigonometric moment shadow mapping with two complex moments (thesis app. B.4; supplement 000
// §7.4). See trigonometric_msm.h for the conventions. Both precisions run the same closed form
// of thesis §B.4.1; they differ in how C(c')⁻¹ and the critical points of eq. B.7 are found.
#include "transient/reconstruct/trigonometric_msm.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <complex>
#include <numbers>
#include <type_traits>

#include "transient/reconstruct/polynomial.h"

namespace transient {
namespace {

template <typename Real>
using Cx = std::complex<Real>;

// The Hermitian inverse M = C(c')⁻¹ of the 3x3 Toeplitz matrix, stored in full.
template <typename Real>
using Inverse3 = std::array<std::array<Cx<Real>, 3>, 3>;

// c(φ) = (1, e^{iφ}, e^{2iφ}).
template <typename Real>
std::array<Cx<Real>, 3> MomentGenerator(Real phi) {
  const Cx<Real> x(std::cos(phi), std::sin(phi));
  return {Cx<Real>(1), x, x * x};
}

template <typename Real>
std::array<Cx<Real>, 3> Apply(const Inverse3<Real>& m, const std::array<Cx<Real>, 3>& v) {
  std::array<Cx<Real>, 3> r;
  for (int j = 0; j < 3; ++j) r[j] = m[j][0] * v[0] + m[j][1] * v[1] + m[j][2] * v[2];
  return r;
}

// u* v.
template <typename Real>
Cx<Real> Dot(const std::array<Cx<Real>, 3>& u, const std::array<Cx<Real>, 3>& v) {
  return std::conj(u[0]) * v[0] + std::conj(u[1]) * v[1] + std::conj(u[2]) * v[2];
}

template <typename Real>
Real Saturate(Real value) {
  return value >= Real(0) ? std::min(value, Real(1)) : Real(0);  // NaN -> 0
}

// Biased moments c' = (1 - α) c / t_0 + α e_0 as (c'_1, c'_2) (c'_0 = 1); false when the input
// carries no usable information.
template <typename Real>
bool BiasedMoments(const std::array<Real, kTrigonometricMomentCount>& t, Real alpha,
                   Cx<Real>* c1, Cx<Real>* c2) {
  for (const Real v : t) {
    if (!std::isfinite(v)) return false;
  }
  if (!(t[0] > Real(0)) || !(alpha >= Real(0) && alpha < Real(1))) return false;
  const Real keep = (Real(1) - alpha) / t[0];
  *c1 = keep * Cx<Real>(t[1], t[2]);
  *c2 = keep * Cx<Real>(t[3], t[4]);
  return true;
}

// Reference: Eigen's Cholesky of C(c') = (c_{j-k}); false unless positive definite.
bool InvertReference(Complex c1, Complex c2, Inverse3<double>* m) {
  Eigen::Matrix3cd toeplitz;
  toeplitz << 1.0, std::conj(c1), std::conj(c2), c1, 1.0, std::conj(c1), c2, c1, 1.0;
  const Eigen::LLT<Eigen::Matrix3cd> cholesky(toeplitz);
  if (cholesky.info() != Eigen::Success) return false;
  const Eigen::Matrix3cd inverse = cholesky.solve(Eigen::Matrix3cd::Identity());
  if (!inverse.allFinite()) return false;
  for (int j = 0; j < 3; ++j) {
    for (int k = 0; k < 3; ++k) (*m)[j][k] = inverse(j, k);
  }
  return true;
}

// Single precision: C = L D Lᴴ with unit lower L, then M = L⁻ᴴ D⁻¹ L⁻¹. Pivots are the
// prediction-error variances (1, 1 - |c1|², ...), >= α for valid biased moments; a pivot below
// half of α (rounding cannot get there from a valid input) means invalid moments.
bool InvertFloat(Cx<float> c1, Cx<float> c2, float alpha, Inverse3<float>* m) {
  const float min_pivot = 0.5f * alpha;
  const float d0 = 1.0f;
  const Cx<float> l10 = c1, l20 = c2;
  const float d1 = 1.0f - std::norm(c1);
  if (!(d1 >= min_pivot)) return false;
  const Cx<float> l21 = (c1 - l20 * std::conj(l10)) / d1;  // (C_21 - l20 d0 conj(l10)) / d1
  const float d2 = 1.0f - std::norm(l20) - d1 * std::norm(l21);
  if (!(d2 >= min_pivot)) return false;
  // L⁻¹ (unit lower): rows (1,0,0), (-l10,1,0), (l21 l10 - l20, -l21, 1).
  const Cx<float> i10 = -l10, i21 = -l21, i20 = l21 * l10 - l20;
  const float inv_d[3] = {1.0f / d0, 1.0f / d1, 1.0f / d2};
  const Cx<float> linv[3][3] = {{1.0f, 0.0f, 0.0f}, {i10, 1.0f, 0.0f}, {i20, i21, 1.0f}};
  // M_jk = Σ_l conj(Linv_lj) Linv_lk / d_l.
  for (int j = 0; j < 3; ++j) {
    for (int k = j; k < 3; ++k) {
      Cx<float> sum = 0.0f;
      for (int l = std::max(j, k); l < 3; ++l) sum += std::conj(linv[l][j]) * linv[l][k] * inv_d[l];
      (*m)[j][k] = sum;
      (*m)[k][j] = std::conj(sum);
    }
    (*m)[j][j] = std::real((*m)[j][j]);
  }
  return true;
}

// Roots x of q_0 x² + q_1 x + q_2 (the kernel polynomial Σ_j q_j e^{-ijθ} = c(θ)* q of alg. B.2
// times x²) as phases, sorted. In exact arithmetic both lie on the unit circle; their product is
// q_2 / q_0, which gives the second root without cancellation.
template <typename Real>
void KernelRootPhases(const std::array<Cx<Real>, 3>& q, Real* phi_low, Real* phi_high) {
  const Cx<Real> root = std::sqrt(q[1] * q[1] - Real(4) * q[0] * q[2]);
  const Cx<Real> plus = -q[1] + root, minus = -q[1] - root;
  const Cx<Real> big = std::norm(plus) >= std::norm(minus) ? plus : minus;
  const Cx<Real> x1 = big / (Real(2) * q[0]);
  const Cx<Real> x2 = q[2] / (q[0] * x1);
  const Real a = std::arg(x1), b = std::arg(x2);
  *phi_low = std::min(a, b);
  *phi_high = std::max(a, b);
}

// The real trigonometric polynomial P(θ) = Re(conj(N) Den(θ)) of eq. B.7, with w_1 = |N|² / P,
// N = Q(φ_f, π) and Den(θ) = N Q(θ, θ) - Q(φ_f, θ) Q(θ, π), Q(a, b) = c(a)* M c(b).
// P(θ) = p0 + 2 Re(p1 e^{iθ}) + 2 Re(p2 e^{2iθ}).
template <typename Real>
struct DenominatorPolynomial {
  Real p0;
  Cx<Real> p1, p2;

  Real Value(Real theta) const {
    const Cx<Real> x(std::cos(theta), std::sin(theta));
    return p0 + Real(2) * std::real(p1 * x + p2 * x * x);
  }
  // P'(θ) = -2 Im(p1 e^{iθ}) - 4 Im(p2 e^{2iθ}).
  Real Slope(Real theta) const {
    const Cx<Real> x(std::cos(theta), std::sin(theta));
    return Real(-2) * std::imag(p1 * x) - Real(4) * std::imag(p2 * x * x);
  }
};

template <typename Real>
DenominatorPolynomial<Real> MakeDenominator(const Inverse3<Real>& m, const Cx<Real>& n,
                                            const std::array<Cx<Real>, 3>& c_f,
                                            const std::array<Cx<Real>, 3>& c_pi) {
  // Q(θ, θ) = Σ_d e^{idθ} s_d, s_d = Σ_{k-j=d} M_jk; Q(φ_f, θ) = Σ_k g_k e^{ikθ}, g = Mᵀ conj(c_f);
  // Q(θ, π) = Σ_j h_j e^{-ijθ}, h = M c_π.
  const std::array<Cx<Real>, 3> h = Apply(m, c_pi);
  std::array<Cx<Real>, 3> g;
  for (int k = 0; k < 3; ++k) {
    g[k] = std::conj(c_f[0]) * m[0][k] + std::conj(c_f[1]) * m[1][k] + std::conj(c_f[2]) * m[2][k];
  }
  std::array<Cx<Real>, 5> e{};  // Den(θ) = Σ_{d=-2..2} e[d+2] e^{idθ}
  for (int j = 0; j < 3; ++j) {
    for (int k = 0; k < 3; ++k) e[k - j + 2] += n * m[j][k] - g[k] * h[j];
  }
  const Cx<Real> nc = std::conj(n);
  DenominatorPolynomial<Real> p;
  p.p0 = std::real(nc * e[2]);
  // conj(N) Den is real: its e^{-idθ} coefficient is the conjugate of its e^{idθ} one; average
  // both to cancel rounding.
  p.p1 = Real(0.5) * (nc * e[3] + std::conj(nc * e[1]));
  p.p2 = Real(0.5) * (nc * e[4] + std::conj(nc * e[0]));
  return p;
}

// Critical points of P in (-π, φ_f): reference by the quartic 2p2 x⁴ + p1 x³ - conj(p1) x -
// 2 conj(p2) = 0 (x = e^{iθ}; P' = 0 times x²/i) and polynomial.h's companion-matrix roots,
// keeping those near the unit circle.
int CriticalPhasesReference(const DenominatorPolynomial<double>& p, double phi_f,
                            std::array<double, 4>* phases) {
  const std::array<Complex, 5> coefficients = {-2.0 * std::conj(p.p2), -std::conj(p.p1), 0.0,
                                               p.p1, 2.0 * p.p2};
  std::array<Complex, 4> roots;
  const int degree = PolynomialRoots(coefficients, roots);
  int count = 0;
  for (int l = 0; l < degree; ++l) {
    constexpr double kOnCircle = 1e-6;  // roots of a self-inversive quartic pair up as x, 1/x̄
    if (std::abs(std::abs(roots[l]) - 1.0) > kOnCircle) continue;
    const double theta = std::arg(roots[l]);
    if (theta < phi_f) (*phases)[count++] = theta;
  }
  return count;
}

// Single precision: sign changes of P' on a grid of kGrid phases over (-π, φ_f), each refined by
// bisection to ~1e-6 rad. Critical points closer than the grid spacing come in pairs of a
// shallow maximum and minimum; missing such a pair changes P by less than its variation over
// one grid cell.
int CriticalPhasesFloat(const DenominatorPolynomial<float>& p, float phi_f,
                        std::array<float, 4>* phases) {
  constexpr int kGrid = 24;
  constexpr int kBisections = 20;
  const float low = -std::numbers::pi_v<float>;
  const float step = (phi_f - low) / kGrid;
  int count = 0;
  float a = low, slope_a = p.Slope(a);
  for (int l = 1; l <= kGrid && count < 4; ++l) {
    const float b = l == kGrid ? phi_f : low + step * static_cast<float>(l);
    const float slope_b = p.Slope(b);
    if ((slope_a > 0.0f) != (slope_b > 0.0f)) {
      float lo = a, hi = b, slope_lo = slope_a;
      for (int k = 0; k < kBisections; ++k) {
        const float mid = 0.5f * (lo + hi);
        const float slope_mid = p.Slope(mid);
        if ((slope_mid > 0.0f) == (slope_lo > 0.0f)) {
          lo = mid;
          slope_lo = slope_mid;
        } else {
          hi = mid;
        }
      }
      (*phases)[count++] = 0.5f * (lo + hi);
    }
    a = b;
    slope_a = slope_b;
  }
  return count;
}

// Relative slack in 1 - w_1 Q(θ,θ) below which the remainder counts as singular.
template <typename Real>
constexpr Real kSingularSlack = std::is_same_v<Real, float> ? Real(1e-2) : Real(1e-4);

// Thesis §B.4.1 on M = C(c')⁻¹ and φ_f ∈ (-π, π].
template <typename Real, typename CriticalPhases>
Real OcclusionFromInverse(const Inverse3<Real>& m, Real phi_f, CriticalPhases critical_phases) {
  const Real pi = std::numbers::pi_v<Real>;
  const std::array<Cx<Real>, 3> c_f = MomentGenerator(phi_f);
  const std::array<Cx<Real>, 3> c_pi = {Cx<Real>(1), Cx<Real>(-1), Cx<Real>(1)};
  const std::array<Cx<Real>, 3> m_pi = Apply(m, c_pi);
  // Case decision (end of §B.4.1): the canonical representation with support at π (alg. B.2)
  // has support φ_1 < φ_2 besides π; eq. B.5 says which weights lie in front of φ_f.
  Real phi_1, phi_2;
  KernelRootPhases(m_pi, &phi_1, &phi_2);
  if (!(phi_f > phi_1)) return Real(0);  // also NaN phases: nothing known
  const std::array<Cx<Real>, 3> m_f = Apply(m, c_f);
  if (phi_f > phi_2) {
    // Both in front: minimise 1 - w_0 - w_3 over the weight w_3 at π (eq. B.6, Lemma B.8),
    // w_3 = (|Q(π,f)| - Q(f,f)) / (|Q(π,f)|² - Q(f,f) Q(π,π)), kept in [0, 1/Q(π,π)] where
    // c' - w_3 c(π) stays a moment vector.
    const Real a = std::real(Dot(c_f, m_f)), b = std::real(Dot(c_pi, m_pi));
    const Real r = std::abs(Dot(c_pi, m_f));
    const Real denominator = a * b - r * r;  // >= 0 by Cauchy-Schwarz
    Real w3 = denominator > Real(0) ? (a - r) / denominator : Real(0);
    w3 = std::clamp(w3, Real(0), Real(1) / b);
    // 1 - w_3 - 1/g, g = a + w_3 r² / (1 - w_3 b), written without dividing by 1 - w_3 b.
    const Real rest = Real(1) - w3 * b;
    return Saturate(Real(1) - w3 - rest / (a * rest + w3 * r * r));
  }
  // φ_1 < φ_f <= φ_2: only the weight w_1 at a point θ < φ_f lies in front; eq. B.7 gives it as
  // a function of θ for distributions with support {θ, φ_f, φ_2', π}; minimise over the
  // critical points θ of its denominator. A candidate counts only when it is a distribution:
  // w_1 <= 1/Q(θ,θ) (the remainder c' - w_1 c(θ) stays a moment vector) and the remainder's
  // third support point φ_2' does not lie in front of φ_f.
  const Cx<Real> n = Dot(c_f, m_pi);  // Q(φ_f, π)
  const DenominatorPolynomial<Real> p = MakeDenominator(m, n, c_f, c_pi);
  std::array<Real, 4> phases;
  const int count = critical_phases(p, phi_f, &phases);
  const Real n2 = std::norm(n);
  // Two feasible distributions bound the minimum from above and stand in where the critical
  // points are not feasible (near-singular C(c), where the optimum sits on the boundary
  // w_1 = 1/Q(θ,θ) rather than at a critical point): the canonical representation with support
  // at π (w_1 = 1/Q(φ_1, φ_1)), and the one with support at φ_f (w_3 = 0), whose mass in front
  // is that of its other two support points.
  const std::array<Cx<Real>, 3> c_1 = MomentGenerator(phi_1);
  Real best = Real(1) / std::real(Dot(c_1, Apply(m, c_1)));
  Real psi_1, psi_2;
  KernelRootPhases(m_f, &psi_1, &psi_2);
  Real at_f = Real(0);
  for (const Real psi : {psi_1, psi_2}) {
    const std::array<Cx<Real>, 3> c_psi = MomentGenerator(psi);
    if (psi < phi_f) at_f += Real(1) / std::real(Dot(c_psi, Apply(m, c_psi)));
  }
  best = std::min(best, at_f);
  bool found = true;
  for (int l = 0; l < count; ++l) {
    const Real theta = phases[l];
    const Real value = p.Value(theta);
    if (!(value > Real(0))) continue;
    const Real w1 = n2 / value;
    const std::array<Cx<Real>, 3> c_t = MomentGenerator(theta);
    const std::array<Cx<Real>, 3> m_t = Apply(m, c_t);
    const Real q_tt = std::real(Dot(c_t, m_t));
    const Real rest = Real(1) - w1 * q_tt;
    // At the optimum of a (nearly) singular C(c), e.g. one or two surfaces, w_1 is the largest
    // mass that θ can carry, 1/Q(θ,θ), and rounding in P (whose size grows like 1/α²) puts it on
    // either side: accept a small overshoot as that limit.
    if (!(rest > -kSingularSlack<Real>)) continue;
    if (rest > kSingularSlack<Real>) {
      // q_r = (C(c') - w_1 c(θ) c(θ)*)⁻¹ c(φ_f) by Lemma B.8; its kernel polynomial has roots π
      // and φ_2', whose product is q_r2 / q_r0.
      const Cx<Real> scale = w1 * Dot(c_t, m_f) / rest;
      const Cx<Real> q0 = m_f[0] + scale * m_t[0], q2 = m_f[2] + scale * m_t[2];
      const Real phi_2_rest = std::arg(-q2 / q0);
      if (phi_2_rest < phi_f && phi_2_rest > -pi + kSingularSlack<Real>) continue;
    }
    best = std::min(best, std::min(w1, Real(1) / q_tt));
    found = true;
  }
  return found ? Saturate(best) : Real(0);
}

template <typename Real>
bool ClampedPhase(Real z_f, Real* phi_f) {
  if (std::isnan(z_f)) return false;
  const Real kappa = static_cast<Real>(kTrigonometricPhaseScale);
  const Real pi = std::numbers::pi_v<Real>;
  *phi_f = std::clamp(kappa * pi * z_f, -pi, pi);
  return *phi_f > -pi;  // φ_f = -π: the interval (-π, φ_f) is empty
}

}  // namespace

double TrigonometricPhase(double z) { return kTrigonometricPhaseScale * std::numbers::pi * z; }

DepthSample DepthTrigonometricMoments(double depth_m, const DepthNormalisation& normalisation,
                                      TrigonometricMoments* moments) {
  PowerMoments power;
  const DepthSample sample = DepthMoments(depth_m, normalisation, &power);
  if (sample == DepthSample::kInvalid) {
    moments->fill(0.0);
    return sample;
  }
  const double phi = TrigonometricPhase(power[1]);  // power[1] is the clamped z̄
  *moments = {1.0, std::cos(phi), std::sin(phi), std::cos(2.0 * phi), std::sin(2.0 * phi)};
  return sample;
}

double TrigonometricOcclusionReference(const TrigonometricMoments& moments, double z_f,
                                       double alpha) {
  Complex c1, c2;
  double phi_f;
  if (!BiasedMoments(moments, alpha, &c1, &c2) || !ClampedPhase(z_f, &phi_f)) return 0.0;
  Inverse3<double> m;
  if (!InvertReference(c1, c2, &m)) return 0.0;
  return OcclusionFromInverse(m, phi_f, CriticalPhasesReference);
}

float TrigonometricOcclusion(const TrigonometricMomentsF& moments, float z_f, float alpha) {
  Cx<float> c1, c2;
  float phi_f;
  if (!BiasedMoments(moments, alpha, &c1, &c2) || !ClampedPhase(z_f, &phi_f)) return 0.0f;
  Inverse3<float> m;
  if (!InvertFloat(c1, c2, alpha, &m)) return 0.0f;
  return OcclusionFromInverse(m, phi_f, CriticalPhasesFloat);
}

}  // namespace transient

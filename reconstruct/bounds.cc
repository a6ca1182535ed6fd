// Error bounds of the Poisson-smoothed density (thesis prop. 8.4, Karlsson & Georgiou 2013).
#include "transient/reconstruct/bounds.h"

#include <Eigen/Cholesky>
#include <array>
#include <cassert>
#include <cmath>

namespace transient {

double PoissonKernel(double r, double phase) {
  return (1.0 - r * r) / (kTwoPi * std::norm(1.0 - std::polar(r, phase)));
}

bool PoissonBounds(std::span<const Complex> c, double r, std::span<const double> phases,
                   std::span<double> lower, std::span<double> upper) {
  assert(r > 0.0 && r < 1.0);
  assert(phases.size() == lower.size() && phases.size() == upper.size());
  const int size = static_cast<int>(c.size());
  // Karlsson & Georgiou (and the proposition) write moments as int exp(-i j phi) dF, the
  // complex conjugates of ours (DESIGN.md, thesis eq. 8.1): we apply it to conj(c).
  std::array<Complex, kMaxMoments> conjugate;
  for (int j = 0; j < size; ++j) conjugate[j] = std::conj(c[j]);
  const std::span<const Complex> k(conjugate.data(), size);
  const ToeplitzMatrix t = MakeToeplitz(k);
  Eigen::LLT<ToeplitzMatrix> cholesky(t);
  if (cholesky.info() != Eigen::Success) return false;

  SmallVector d(size), e(size);
  for (size_t n = 0; n < phases.size(); ++n) {
    const Complex x = std::polar(r, phases[n]);
    // The proposition uses d_j = x^{-j-1} and e_j = x^{-j-1} (c_0 + 2 sum_{k=1..j} c_k x^k).
    // We scale both by s = x^{m+1} (d_j = x^{m-j}) so nothing overflows for small r; every
    // quadratic form then carries |s|^2, which we also apply to the 2/(1-|x|^2) term of Q.
    Complex partial = k[0].real();
    Complex x_power = 1.0;
    for (int j = 0; j < size; ++j) {
      if (j > 0) {
        x_power *= x;
        partial += 2.0 * k[j] * x_power;
      }
      d(j) = std::pow(x, size - 1 - j);
      e(j) = d(j) * partial;
    }
    const double scale = std::pow(r, 2 * size);  // |s|^2
    const SmallVector inverse_d = cholesky.solve(d);
    const SmallVector inverse_e = cholesky.solve(e);
    const double dd = d.dot(inverse_d).real();  // Eigen's dot conjugates its first argument
    const Complex ed = e.dot(inverse_d);
    const double ee = e.dot(inverse_e).real();
    const Complex q = (2.0 * scale / (1.0 - r * r) + ed) / dd;
    const double radius_squared = std::norm(q) - ee / dd;
    const double radius = std::sqrt(std::max(radius_squared, 0.0));
    lower[n] = (q.real() - radius) / kTwoPi;
    upper[n] = (q.real() + radius) / kTwoPi;
  }
  return true;
}

}  // namespace transient

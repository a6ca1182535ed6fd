// A depth distribution Σ w_l δ_{z_l} on [-1, 1] (normalised depth, weights summing to 1), its
// power and trigonometric moments, and the exact answers the occlusion tests compare against.
// Shared by the power-moment (thesis ch. 4) and trigonometric (app. B.4) MSM tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "transient/reconstruct/power_moments.h"
#include "transient/reconstruct/trigonometric_msm.h"

namespace transient::testing {

struct DepthMixture {
  std::vector<double> z, w;

  // b_j = Σ w_l z_l^j, j = 0..4.
  PowerMoments Powers() const {
    PowerMoments b{};
    for (size_t l = 0; l < z.size(); ++l) {
      double power = 1.0;
      for (int j = 0; j < kPowerMomentCount; ++j, power *= z[l]) b[j] += w[l] * power;
    }
    return b;
  }
  // (Σ w, Re and Im of Σ w e^{iφ}, of Σ w e^{2iφ}) at φ = TrigonometricPhase(z).
  TrigonometricMoments Trigonometric() const {
    TrigonometricMoments t{};
    for (size_t l = 0; l < z.size(); ++l) {
      const double phi = TrigonometricPhase(z[l]);
      t[0] += w[l];
      t[1] += w[l] * std::cos(phi);
      t[2] += w[l] * std::sin(phi);
      t[3] += w[l] * std::cos(2.0 * phi);
      t[4] += w[l] * std::sin(2.0 * phi);
    }
    return t;
  }
  // The exact fraction strictly in front of z_f.
  double FractionInFront(double z_f) const {
    double f = 0.0;
    for (size_t l = 0; l < z.size(); ++l) f += z[l] < z_f ? w[l] : 0.0;
    return f;
  }
  double DistanceTo(double z_f) const {
    double d = std::numeric_limits<double>::infinity();
    for (const double zl : z) d = std::min(d, std::abs(zl - z_f));
    return d;
  }
};

}  // namespace transient::testing

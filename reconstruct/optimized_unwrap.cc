// The optimized phase unwrapping (phase_unwrapping.h): UnwrapPixel's arithmetic for eight
// pixels at once, one SIMD lane per pixel (kernels_simd.h). Every lane does the IEEE operations
// of UnwrapPixel in the same order (this file is compiled without fused multiply-adds, as
// optimized_solve.cc), and the transcendental functions (the highest harmonic's argument, the
// first candidate's e^{-i theta_0}, large Newton rotations) are the same library calls per
// lane, so the results equal UnwrapPixel's bit for bit (tests/reconstruct/phase_unwrapping_test).
// The J candidates are scored for all lanes together (J is the same for every pixel), and the
// Newton steps run while any lane still rises, masked per lane.
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include "kernels_internal.h"
#include "kernels_simd.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/phase_unwrapping.h"

namespace transient::internal {
namespace {

using simd::Abs;
using simd::Any;
using simd::kLanes;
using simd::Select;
using simd::Splat;
using simd::Vd;
using simd::Vm;

struct Cv {  // eight complex numbers
  Vd re, im;
};

__attribute__((always_inline)) inline Cv Multiply(Cv a, Cv b) {
  return {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re};
}

// Power() (kernels_internal.h), lane by lane: the same products in the same order.
__attribute__((always_inline)) inline Cv PowerV(Cv x, int n) {
  Cv result{Splat(1.0), Splat(0.0)};
  for (; n > 0; n >>= 1) {
    if (n & 1) result = Multiply(result, x);
    x = Multiply(x, x);
  }
  return result;
}

struct ScoreV {
  Vd value, slope, curvature;
};

// Evaluate() of phase_unwrapping.cc.
__attribute__((always_inline)) inline ScoreV EvaluateV(const Cv* c, std::span<const int> harmonics,
                                                       Cv unit) {
  ScoreV s{Splat(0.0), Splat(0.0), Splat(0.0)};
  for (size_t i = 0; i < harmonics.size(); ++i) {
    const double j = harmonics[i];
    const Cv z = Multiply(c[i], PowerV(unit, harmonics[i]));
    s.value += z.re;
    s.slope += j * z.im;
    s.curvature -= j * j * z.re;
  }
  return s;
}

// Rotation() of phase_unwrapping.cc: the Taylor series where |delta| <= 0.1, else the library's
// sine and cosine, lane by lane.
__attribute__((always_inline)) inline Cv RotationV(Vd delta) {
  const Vd d2 = delta * delta;
  Cv r{1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0 * (1.0 - d2 / 56.0))),
       delta * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0 * (1.0 - d2 / 42.0 * (1.0 - d2 / 72.0))))};
  const Vm large = ~(Abs(delta) <= 0.1);
  if (Any(large)) {
    for (int l = 0; l < kLanes; ++l) {
      if (large[l] == 0) continue;
      const std::complex<double> p = std::polar(1.0, delta[l]);
      r.re[l] = p.real();
      r.im[l] = p.imag();
    }
  }
  return r;
}

__attribute__((always_inline)) inline void UnwrapBody(const MomentImage& moments,
                                                      const UnwrapOptions& options, int64_t begin,
                                                      int64_t end, UnwrapOutputs out) {
  const std::span<const int> harmonics = options.harmonics;
  const size_t count = harmonics.size();
  size_t top = 0;
  for (size_t i = 0; i < count; ++i) {
    if (harmonics[i] > harmonics[top]) top = i;
  }
  const int highest = harmonics[top];
  const std::complex<double> spacing = std::polar(1.0, -kTwoPi / highest);
  // step_i = spacing^{j_i}, and spacing^n for the best candidate n, as UnwrapPixel computes
  // them.
  Cv step[kMaxOrder];
  for (size_t i = 0; i < count; ++i) {
    const std::complex<double> s = Power(spacing, harmonics[i]);
    step[i] = {Splat(s.real()), Splat(s.imag())};
  }
  std::complex<double> spacing_power[kMaxOrder + 1] = {};
  for (int n = 0; n < highest; ++n) spacing_power[n] = Power(spacing, n);
  const double max_step = 0.25 * kTwoPi / highest;
  const double infinity = std::numeric_limits<double>::infinity();

  for (int64_t first = begin; first < end; first += kLanes) {
    const int lanes = static_cast<int>(std::min<int64_t>(kLanes, end - first));
    // Lanes past the end, invalid pixels and pixels UnwrapPixel answers without scoring take
    // the moments 1 + 0i (harmless), and their results are not stored from the vectors.
    bool use[kLanes] = {};
    Cv c[kMaxOrder];
    for (size_t i = 0; i < count; ++i) c[i] = {Splat(1.0), Splat(0.0)};
    for (int l = 0; l < lanes; ++l) {
      const int64_t p = first + l;
      const uint8_t f = moments.flags.empty() ? 0 : (moments.flags[p] & kMomentImageFlags);
      if (!moments.valid.empty() && moments.valid[p] == 0) {
        out.flags[p] = static_cast<uint8_t>(f | kFlagInvalidInput);
        continue;
      }
      std::complex<float> pixel[kMaxOrder];
      for (size_t i = 0; i < count; ++i) {
        pixel[i] = {moments.real_plane(harmonics[i])[p], moments.imag_plane(harmonics[i])[p]};
      }
      // The pixels that UnwrapPixel answers before scoring (non-finite, no light, too little):
      // by UnwrapPixel itself.
      double total = 0.0;
      for (size_t i = 0; i < count; ++i) {
        total += std::sqrt(std::norm(std::complex<double>(pixel[i].real(), pixel[i].imag())));
      }
      if (!std::isfinite(total) || total == 0.0 ||
          total / static_cast<double>(count) < options.min_amplitude) {
        const UnwrappedPixel u = UnwrapPixel({pixel, count}, options);
        if (!std::isfinite(u.amplitude)) {
          out.flags[p] = static_cast<uint8_t>(f | kFlagInvalidInput);
          continue;
        }
        out.flags[p] = static_cast<uint8_t>(f | u.flags);
        out.amplitude[p] = static_cast<float>(u.amplitude);
        out.confidence[p] = static_cast<float>(u.confidence);
        out.range_m[p] = static_cast<float>(u.range_m);
        continue;
      }
      use[l] = true;
      for (size_t i = 0; i < count; ++i) {
        c[i].re[l] = pixel[i].real();
        c[i].im[l] = pixel[i].imag();
      }
    }
    bool any = false;
    for (int l = 0; l < lanes; ++l) any |= use[l];
    if (!any) continue;

    // sum_i sqrt(std::norm(c_i)), std::norm being re^2 + im^2 in libstdc++.
    Vd total = Splat(0.0);
    for (size_t i = 0; i < count; ++i) {
      const Vd squared = c[i].re * c[i].re + c[i].im * c[i].im;
      total += simd::Sqrt(squared);
    }
    // theta_0 = arg(c_J) / J and e^{-i theta_0}, per lane.
    Vd theta0 = Splat(0.0);
    alignas(64) double start_re[kLanes], start_im[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      theta0[l] = std::arg(std::complex<double>(c[top].re[l], c[top].im[l])) / highest;
      const std::complex<double> s = std::polar(1.0, -theta0[l]);
      start_re[l] = s.real();
      start_im[l] = s.imag();
    }
    const Cv start{simd::Load(start_re), simd::Load(start_im)};
    Cv z[kMaxOrder];
    for (size_t i = 0; i < count; ++i) z[i] = Multiply(c[i], PowerV(start, harmonics[i]));
    Vd best = Splat(-infinity), second = best, best_n = Splat(0.0);
    for (int n = 0; n < highest; ++n) {
      Vd score = Splat(0.0);
      for (size_t i = 0; i < count; ++i) {
        score += z[i].re;
        const Vd re = z[i].re * step[i].re - z[i].im * step[i].im;
        z[i] = {re, z[i].re * step[i].im + z[i].im * step[i].re};
      }
      const Vm higher = score > best;
      second = Select(higher, best, Select(score > second, score, second));
      best = Select(higher, score, best);
      best_n = Select(higher, Splat(n), best_n);
    }

    Vd theta = theta0 + kTwoPi * best_n / highest;
    Vd best_theta = theta;
    // e^{-i theta} = e^{-i theta_0} spacing^n, per lane (n differs).
    double unit_re[kLanes], unit_im[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      const std::complex<double> u = std::complex<double>(start.re[l], start.im[l]) *
                                     spacing_power[static_cast<int>(best_n[l])];
      unit_re[l] = u.real();
      unit_im[l] = u.imag();
    }
    Cv unit{simd::Load(unit_re), simd::Load(unit_im)};
    ScoreV s = EvaluateV(c, harmonics, unit);
    Vm active = Splat(0.0) == Splat(0.0);
    for (int k = 0; k < options.newton_steps; ++k) {
      active &= s.curvature < 0.0;  // not at a maximum: keep the best point so far
      if (!Any(active)) break;
      Vd delta = s.slope / s.curvature;
      delta = Select(delta < -max_step, Splat(-max_step),
                     Select(delta > max_step, Splat(max_step), delta));
      delta = Select(active, delta, Splat(0.0));
      theta = Select(active, theta - delta, theta);
      const Cv moved = Multiply(unit, RotationV(delta));
      unit = {Select(active, moved.re, unit.re), Select(active, moved.im, unit.im)};
      s = EvaluateV(c, harmonics, unit);
      active &= s.value > best;
      best = Select(active, s.value, best);
      best_theta = Select(active, theta, best_theta);
    }

    for (int l = 0; l < lanes; ++l) {
      if (!use[l]) continue;
      const int64_t p = first + l;
      const uint8_t f = moments.flags.empty() ? 0 : (moments.flags[p] & kMomentImageFlags);
      out.amplitude[p] = static_cast<float>(total[l] / static_cast<double>(count));
      out.confidence[p] = static_cast<float>(best[l] / total[l]);
      if (highest > 1 && (best[l] - second[l]) / total[l] < options.ambiguity_margin) {
        out.flags[p] = static_cast<uint8_t>(f | kFlagAmbiguous);
        continue;  // range_m stays NaN
      }
      out.flags[p] = f;
      out.range_m[p] =
          static_cast<float>(PhaseToRange(WrapPhase(best_theta[l]), options.base_frequency_hz));
    }
  }
}

}  // namespace

TRANSIENT_SIMD_VARIANTS(UnwrapPixels, UnwrapBody,
                        (const MomentImage& moments, const UnwrapOptions& options, int64_t begin,
                         int64_t end, UnwrapOutputs out),
                        (moments, options, begin, end, out))

}  // namespace transient::internal

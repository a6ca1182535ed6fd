// Range by single-return maximum-likelihood phase unwrapping (phase_unwrapping.h).
#include "transient/reconstruct/phase_unwrapping.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "kernels_internal.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

using ComplexF = std::complex<float>;

// S(theta), S'(theta), S''(theta) of the matched filter at theta.
struct Score {
  double value, slope, curvature;
};

using internal::Power;

// S and its derivatives at the phase theta given as unit = e^{-i theta}.
Score Evaluate(std::span<const std::complex<double>> c, std::span<const int> harmonics,
               std::complex<double> unit) {
  Score s{0.0, 0.0, 0.0};
  for (size_t i = 0; i < c.size(); ++i) {
    const double j = harmonics[i];
    const std::complex<double> z = c[i] * Power(unit, harmonics[i]);
    s.value += z.real();
    s.slope += j * z.imag();
    s.curvature -= j * j * z.real();
  }
  return s;
}

// e^{i delta}: Taylor's series through delta^9 for the small steps of Newton's method
// (|delta| <= 0.1: error < 1e-16), a sine and cosine otherwise.
std::complex<double> Rotation(double delta) {
  if (!(std::abs(delta) <= 0.1)) return std::polar(1.0, delta);
  const double d2 = delta * delta;
  const double cosine = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0 * (1.0 - d2 / 56.0)));
  const double sine =
      delta * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0 * (1.0 - d2 / 42.0 * (1.0 - d2 / 72.0))));
  return {cosine, sine};
}

// e^{-2 pi i / highest}, the same for every pixel of an image: kept per thread.
std::complex<double> CandidateSpacing(int highest) {
  thread_local int cached_highest = 0;
  thread_local std::complex<double> cached;
  if (highest != cached_highest) {
    cached = std::polar(1.0, -kTwoPi / highest);
    cached_highest = highest;
  }
  return cached;
}

}  // namespace

absl::Status UnwrapOptions::Validate() const {
  auto violated = [](absl::string_view field, auto value, absl::string_view rule) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, " = ", value, ". Violated constraint: ", rule));
  };
  if (!std::isfinite(base_frequency_hz) || base_frequency_hz <= 0.0) {
    return violated("base_frequency_hz", base_frequency_hz, "finite and > 0");
  }
  if (harmonics.empty() || static_cast<int>(harmonics.size()) > kMaxOrder) {
    return violated("harmonics", absl::StrJoin(harmonics, ","),
                    absl::StrCat("1 to ", kMaxOrder, " harmonics"));
  }
  int common = 0;
  for (int j : harmonics) {
    if (j < 1 || j > kMaxOrder) {
      return violated("harmonics", absl::StrJoin(harmonics, ","),
                      absl::StrCat("each in 1..", kMaxOrder));
    }
    common = std::gcd(common, j);
  }
  if (common > 1) {  // every distance would have `common` equal candidates
    return violated("harmonics", absl::StrJoin(harmonics, ","),
                    absl::StrCat("no common factor (", common, ")"));
  }
  if (!(min_amplitude >= 0.0) || !std::isfinite(min_amplitude)) {
    return violated("min_amplitude", min_amplitude, "finite and >= 0");
  }
  if (!(ambiguity_margin >= 0.0 && ambiguity_margin <= 2.0)) {
    return violated("ambiguity_margin", ambiguity_margin, "0 <= ambiguity_margin <= 2");
  }
  if (newton_steps < 0 || newton_steps > 16) {
    return violated("newton_steps", newton_steps, "0 <= newton_steps <= 16");
  }
  return absl::OkStatus();
}

UnwrappedPixel UnwrapPixel(std::span<const ComplexF> moments, const UnwrapOptions& options) {
  assert(options.Validate().ok());
  assert(moments.size() == options.harmonics.size());
  const std::span<const int> harmonics = options.harmonics;
  const size_t count = harmonics.size();
  std::complex<double> c[kMaxOrder];
  double total = 0.0;  // sum |c_j|
  size_t top = 0;      // index of the highest harmonic J
  for (size_t i = 0; i < count; ++i) {
    c[i] = std::complex<double>(moments[i].real(), moments[i].imag());
    total += std::sqrt(std::norm(c[i]));  // floats squared: no overflow, so no hypot
    if (harmonics[i] > harmonics[top]) top = i;
  }
  UnwrappedPixel out;
  out.amplitude = total / static_cast<double>(count);
  if (!std::isfinite(total)) {
    out.range_m = out.amplitude = out.confidence = kNaN;
    return out;
  }
  if (total == 0.0 || out.amplitude < options.min_amplitude) {
    out.flags = kFlagLowAmplitude;
    out.range_m = out.confidence = kNaN;
    return out;
  }

  // The J candidates theta_n = (arg c_J + 2*pi*n) / J, scored by rotating each c_j by the
  // constant step exp(-i*j*2*pi/J) from one candidate to the next.
  const int highest = harmonics[top];
  const double theta0 = std::arg(c[top]) / highest;
  std::complex<double> z[kMaxOrder], step[kMaxOrder];
  const std::complex<double> start = std::polar(1.0, -theta0);
  const std::complex<double> spacing = CandidateSpacing(highest);
  for (size_t i = 0; i < count; ++i) {
    z[i] = c[i] * Power(start, harmonics[i]);
    step[i] = Power(spacing, harmonics[i]);
  }
  double best = -std::numeric_limits<double>::infinity(), second = best;
  int best_n = 0;
  for (int n = 0; n < highest; ++n) {
    double score = 0.0;
    for (size_t i = 0; i < count; ++i) {  // z_i *= step_i in real arithmetic (finite values)
      score += z[i].real();
      const double re = z[i].real() * step[i].real() - z[i].imag() * step[i].imag();
      z[i] = {re, z[i].real() * step[i].imag() + z[i].imag() * step[i].real()};
    }
    if (score > best) {
      second = best;
      best = score;
      best_n = n;
    } else if (score > second) {
      second = score;
    }
  }

  // Newton steps towards the peak of S near the best candidate, each at most a quarter of the
  // candidates' spacing and only while S rises, so that the refinement stays on its peak.
  double theta = theta0 + kTwoPi * best_n / highest;
  const double max_step = 0.25 * kTwoPi / highest;
  double best_theta = theta;
  std::complex<double> unit = start * Power(spacing, best_n);  // e^{-i theta}
  Score s = Evaluate({c, count}, harmonics, unit);
  for (int k = 0; k < options.newton_steps; ++k) {
    if (!(s.curvature < 0.0)) break;  // not at a maximum: keep the best point so far
    const double delta = std::clamp(s.slope / s.curvature, -max_step, max_step);
    theta -= delta;
    unit *= Rotation(delta);
    s = Evaluate({c, count}, harmonics, unit);  // its slope and curvature serve the next step
    if (!(s.value > best)) break;
    best = s.value;
    best_theta = theta;
  }
  theta = best_theta;

  out.confidence = best / total;
  // One harmonic J > 1 alone has J equal candidates: always ambiguous.
  if (highest > 1 && (best - second) / total < options.ambiguity_margin) {
    out.flags |= kFlagAmbiguous;
    out.range_m = kNaN;
    return out;
  }
  out.range_m = PhaseToRange(WrapPhase(theta), options.base_frequency_hz);
  return out;
}

absl::Status UnwrapImage(const MomentImage& moments, const UnwrapOptions& options,
                         std::vector<float>* range_m, std::vector<float>* amplitude,
                         std::vector<float>* confidence, std::vector<uint8_t>* flags) {
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  const int highest = *std::max_element(options.harmonics.begin(), options.harmonics.end());
  if (moments.order < highest) {
    return absl::InvalidArgumentError(absl::StrCat("moment image of order m = ", moments.order,
                                                   ". Violated constraint: m >= ", highest,
                                                   ", the highest harmonic measured"));
  }
  const int64_t pixels = moments.geometry.pixel_count();
  const size_t n = static_cast<size_t>(pixels);
  range_m->assign(n, kNaNf);
  amplitude->assign(n, kNaNf);
  confidence->assign(n, kNaNf);
  flags->assign(n, 0);
  if (GetKernelOptions().kind == KernelKind::kOptimized) {
    // Eight or four pixels at a time (kernels_simd.h), bit for bit the loop below
    // (optimized_unwrap.cc).
    const internal::UnwrapOutputs out{range_m->data(), amplitude->data(), confidence->data(),
                                      flags->data()};
    internal::ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
      internal::UnwrapPixels(moments, options, begin, end, out);
    });
    return absl::OkStatus();
  }
  // The reference: UnwrapPixel pixel by pixel on one thread.
  const size_t count = options.harmonics.size();
  for (int64_t p = 0; p < pixels; ++p) {
    const size_t q = static_cast<size_t>(p);
    uint8_t f = moments.flags.empty() ? 0 : (moments.flags[q] & kMomentImageFlags);
    if (!moments.valid.empty() && moments.valid[q] == 0) {
      (*flags)[q] = static_cast<uint8_t>(f | kFlagInvalidInput);
      continue;
    }
    ComplexF c[kMaxOrder];
    for (size_t i = 0; i < count; ++i) {
      const int j = options.harmonics[i];
      c[i] = ComplexF(moments.real_plane(j)[p], moments.imag_plane(j)[p]);
    }
    const UnwrappedPixel u = UnwrapPixel({c, count}, options);
    if (!std::isfinite(u.amplitude)) {
      (*flags)[q] = static_cast<uint8_t>(f | kFlagInvalidInput);
      continue;
    }
    (*flags)[q] = static_cast<uint8_t>(f | u.flags);
    (*amplitude)[q] = static_cast<float>(u.amplitude);
    (*confidence)[q] = static_cast<float>(u.confidence);
    (*range_m)[q] = static_cast<float>(u.range_m);
  }
  return absl::OkStatus();
}

}  // namespace transient

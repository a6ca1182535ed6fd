// Effective modulation waveforms and their sub-exposure split (thesis §8.2.1, §8.3.1).
#include "modulation.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace transient::sim {
namespace {

constexpr double kPi = std::numbers::pi;

// x wrapped into [-pi, pi).
double Centered(double x) { return x - kTwoPi * std::floor((x + kPi) / kTwoPi); }

// Antiderivative of the +-1 square wave sign(cos x), periodic because the square has mean 0.
double SquareIntegral(double x) {
  const double u = Centered(x);
  if (u > 0.5 * kPi) return kPi - u;
  if (u < -0.5 * kPi) return -kPi - u;
  return u;
}

// Complex Fourier coefficient S_h of s = sum_h S_h exp(i*h*x) for h >= 1 (S_-h = conj(S_h),
// S_0 = 0). Real because every s here is even.
double Coefficient(Waveform waveform, double duty, int h) {
  if (h % 2 == 0) return 0.0;  // s(x - pi) = -s(x)
  const double sign = ((h - 1) / 2) % 2 == 0 ? 1.0 : -1.0;
  switch (waveform) {
    case Waveform::kSinusoid:
      return h == 1 ? 0.5 : 0.0;
    case Waveform::kTriangle:
      return 4.0 / (kPi * kPi * h * h);
    case Waveform::kSquare: {
      // Square sensor modulation times the illumination pulse's sinc (its mean is 1).
      const double window = h * kPi * duty;
      return 2.0 / (kPi * h) * sign * std::sin(window) / window;
    }
  }
  return 0.0;
}

}  // namespace

double EffectiveModulation(Waveform waveform, double duty, double x) {
  switch (waveform) {
    case Waveform::kSinusoid:
      return std::cos(x);
    case Waveform::kTriangle:
      return 1.0 - 2.0 * std::abs(Centered(x)) / kPi;
    case Waveform::kSquare: {
      // The square sensor modulation averaged over the illumination pulse of width 2*pi*duty.
      const double half = kPi * duty;
      return (SquareIntegral(x + half) - SquareIntegral(x - half)) / (2.0 * half);
    }
  }
  return 0.0;
}

SplitModulation::SplitModulation(Waveform waveform, double duty,
                                 std::span<const SubExposure> split) {
  table_.resize(kTableSize + 1);
  for (int i = 0; i <= kTableSize; ++i) {
    const double x = kTwoPi * i / kTableSize;
    double t = 0.0;
    for (const SubExposure& sub : split) {
      t += sub.weight * EffectiveModulation(waveform, duty, x - sub.phase_shift_rad);
    }
    table_[i] = t;
  }
  const double first = std::abs(Coefficient(waveform, duty, 1));
  int highest = 1;
  for (int h = 1; h <= kMaxHarmonic; ++h) {
    if (std::abs(Coefficient(waveform, duty, h)) >= kRelativeCutoff * first) highest = h;
  }
  coefficients_.assign(highest + 1, Complex(0.0, 0.0));
  for (int h = 1; h <= highest; ++h) {
    const double s = Coefficient(waveform, duty, h);
    if (s == 0.0) continue;
    Complex g(0.0, 0.0);
    for (const SubExposure& sub : split)
      g += sub.weight * std::polar(1.0, -h * sub.phase_shift_rad);
    coefficients_[h] = s * g;
  }
  tail_bound_.assign(highest + 2, 0.0);
  for (int h = highest; h >= 0; --h) {
    tail_bound_[h] = std::max(tail_bound_[h + 1], std::abs(coefficients_[h]));
  }
}

}  // namespace transient::sim

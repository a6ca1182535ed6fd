// 64-bit quantization of four-power-moment texels: thesis eq. 4.4 and supplement 003.
#include "transient/reconstruct/moment_quantization.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace transient {
namespace {

constexpr double kSqrt3 = std::numbers::sqrt3;
constexpr double kCodes = 65535.0;

uint16_t ToCode(double unit) {
  return static_cast<uint16_t>(std::lround(std::clamp(unit, 0.0, 1.0) * kCodes));
}
double FromCode(uint16_t code) { return code / kCodes; }

// b / b_0, or false for input without information.
bool Normalised(const PowerMoments& moments, PowerMoments* b) {
  for (const double m : moments) {
    if (!std::isfinite(m)) return false;
  }
  if (!(moments[0] > 0.0)) return false;
  for (int j = 0; j < kPowerMomentCount; ++j) (*b)[j] = moments[j] / moments[0];
  (*b)[0] = 1.0;
  return true;
}

constexpr PowerMoments kFarPlaneSurface = {1.0, 1.0, 1.0, 1.0, 1.0};

}  // namespace

std::array<double, 4> OptimizedTransform(const PowerMoments& moments) {
  const double inv = 1.0 / moments[0];
  const double b1 = moments[1] * inv, b2 = moments[2] * inv, b3 = moments[3] * inv,
               b4 = moments[4] * inv;
  return {1.5 * b1 - 2.0 * b3 + 0.5, 4.0 * b2 - 4.0 * b4,
          0.5 * kSqrt3 * b1 - (2.0 * kSqrt3 / 9.0) * b3 + 0.5, 0.5 * b2 + 0.5 * b4};
}

PowerMoments InverseOptimizedTransform(const std::array<double, 4>& theta) {
  // Odd block [1.5 -2; √3/2 -2√3/9] has determinant 2√3/3; even block [4 -4; 0.5 0.5] has 4.
  const double x = theta[0] - 0.5, y = theta[2] - 0.5;
  const double b1 = -x / 3.0 + kSqrt3 * y;
  const double b3 = -0.75 * x + 0.75 * kSqrt3 * y;
  const double b2 = 0.125 * theta[1] + theta[3];
  const double b4 = theta[3] - 0.125 * theta[1];
  return {1.0, b1, b2, b3, b4};
}

bool EncodeOptimized64(const PowerMoments& moments, QuantizedMoments64* out) {
  PowerMoments b;
  const bool valid = Normalised(moments, &b);
  const std::array<double, 4> theta = OptimizedTransform(valid ? b : kFarPlaneSurface);
  for (int k = 0; k < 4; ++k) out->channel[k] = ToCode(theta[k]);
  return valid;
}

PowerMoments DecodeOptimized64(const QuantizedMoments64& quantized) {
  std::array<double, 4> theta;
  for (int k = 0; k < 4; ++k) theta[k] = FromCode(quantized.channel[k]);
  return InverseOptimizedTransform(theta);
}

PowerMomentsF DecodeOptimized64F(const QuantizedMoments64& quantized) {
  constexpr float kInvCodes = 1.0f / 65535.0f;
  constexpr float kSqrt3F = static_cast<float>(kSqrt3);
  const float x = quantized.channel[0] * kInvCodes - 0.5f;
  const float y = quantized.channel[2] * kInvCodes - 0.5f;
  const float even1 = quantized.channel[1] * kInvCodes;
  const float even3 = quantized.channel[3] * kInvCodes;
  return {1.0f, std::fma(kSqrt3F, y, -x * (1.0f / 3.0f)),
          std::fma(0.125f, even1, even3), std::fma(0.75f * kSqrt3F, y, -0.75f * x),
          std::fma(-0.125f, even1, even3)};
}

float OcclusionFractionOptimized64(const QuantizedMoments64& quantized, float z_f) {
  return Hamburger4Occlusion(DecodeOptimized64F(quantized), z_f, kQuantized16MomentBias);
}

bool ToNonLinear(const PowerMoments& moments, NonLinearMoments* out) {
  PowerMoments b;
  if (!Normalised(moments, &b)) {
    *out = NonLinearMoments{};
    return false;
  }
  const double mean = b[1];
  const double variance = b[2] - mean * mean;
  NonLinearMoments r;
  if (!(variance > kMinNonLinearVariance)) {
    r.y1 = r.y2 = mean;
    r.v2 = 0.0;
  } else {
    // Centred: the degree-2 orthogonal polynomial is x² - (m3/m2) x - m2, whose roots are real
    // with opposite signs; computing them around the mean avoids the cancellation of the
    // supplement's raw-moment quadratic.
    const double m3 = b[3] - 3.0 * mean * b[2] + 2.0 * mean * mean * mean;
    const double half_slope = 0.5 * m3 / variance;
    const double root = std::sqrt(half_slope * half_slope + variance);
    // Stable pair: the larger-magnitude root directly, the other from the product -m2.
    const double big = half_slope >= 0.0 ? half_slope + root : half_slope - root;
    const double small = -variance / big;
    const double x1 = std::min(big, small), x2 = std::max(big, small);
    r.y1 = mean + x1;
    r.y2 = mean + x2;
    r.v2 = std::clamp(-x1 / (x2 - x1), 0.0, 1.0);
  }
  const double y1_2 = r.y1 * r.y1, y2_2 = r.y2 * r.y2;
  r.xi4 = std::max(b[4] - ((1.0 - r.v2) * y1_2 * y1_2 + r.v2 * y2_2 * y2_2), 0.0);
  *out = r;
  return true;
}

PowerMoments FromNonLinear(const NonLinearMoments& n) {
  PowerMoments b;
  double p1 = 1.0, p2 = 1.0;
  for (int j = 0; j < kPowerMomentCount; ++j) {
    b[j] = (1.0 - n.v2) * p1 + n.v2 * p2;
    p1 *= n.y1;
    p2 *= n.y2;
  }
  b[0] = 1.0;
  b[4] += n.xi4;
  return b;
}

bool EncodeNonLinear64(const PowerMoments& moments, QuantizedMoments64* out) {
  NonLinearMoments n;
  const bool valid = ToNonLinear(moments, &n);
  if (!valid) ToNonLinear(kFarPlaneSurface, &n);
  out->channel[0] = ToCode(0.5 * (std::clamp(n.y1, -1.0, 1.0) + 1.0));
  out->channel[1] = ToCode(0.5 * (std::clamp(n.y2, -1.0, 1.0) + 1.0));
  out->channel[2] = ToCode(n.v2);
  out->channel[3] = ToCode(std::sqrt(4.0 * std::clamp(n.xi4, 0.0, 0.25)));
  return valid;
}

NonLinearMoments DecodeNonLinear64(const QuantizedMoments64& quantized) {
  NonLinearMoments n;
  n.y1 = 2.0 * FromCode(quantized.channel[0]) - 1.0;
  n.y2 = 2.0 * FromCode(quantized.channel[1]) - 1.0;
  n.v2 = FromCode(quantized.channel[2]);
  const double root = FromCode(quantized.channel[3]);
  n.xi4 = 0.25 * root * root;
  return n;
}

}  // namespace transient

// Moment depth maps: moment shadow mapping (thesis ch. 4) on camera depth. See
// moment_depth_map.h for the contract.
#include "transient/reconstruct/moment_depth_map.h"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "absl/strings/str_cat.h"
#include "transient/reconstruct/kernels.h"

namespace transient {
namespace {

// Channels of the filter input: coverage b_0, then b_1..b_4 weighted by coverage.
constexpr int kChannels = kPowerMomentCount;

// A texel whose filtered coverage is at most this is empty (far plane). The filter is a convex
// combination with non-negative float weights, so an all-invalid footprint gives exactly 0 (sums
// of exact zeros), and one valid pixel in the footprint gives at least its kernel weight
// g(r)² >= exp(-9) / (2 pi sigma²) ~ 1e-11 for any filter that fits an image of 4096 px (for
// sigma < 1/3 the outer weights shrink faster, but a pixel weighted below 1e-20 is outside the
// footprint by any practical measure). The threshold also keeps b / b_0 far from overflow and
// from denormal coverage: |b_j| <= b_0 up to rounding, since |z̄| <= 1.
constexpr float kMinCoverage = 1e-20f;

// z̄ = 1: a surface at the far plane, which occludes nothing nearer than `far`.
constexpr float kFarPlane = 1.0f;


// ---- the fast path's loops ---------------------------------------------------------------------
// Compiled for AVX2 and for plain x86-64, chosen at load time (as in optimized_kernels.cc), and
// written branch-free (selects) so that `#pragma omp simd` vectorizes them.

// Pixels per work item of the per-pixel passes.
constexpr int64_t kBlockPixels = 4096;

// Two counts that the per-pixel passes return (what they count is theirs to say).
struct Counts {
  int64_t first = 0, second = 0;
};

// Runs body(begin, end) -> Counts over [0, count) in blocks on KernelThreads() threads; returns the
// sums of the counts.
template <typename Body>
Counts ParallelBlocks(int64_t count, const Body& body) {
  const int64_t blocks = (count + kBlockPixels - 1) / kBlockPixels;
  int64_t first = 0, second = 0;
  // One block: no threads to start and wait for (small images, the tests).
#pragma omp parallel for num_threads(KernelThreads()) schedule(static) reduction(+ : first, second) \
    if (blocks > 1)
  for (int64_t b = 0; b < blocks; ++b) {
    const Counts c = body(b * kBlockPixels, std::min(count, (b + 1) * kBlockPixels));
    first += c.first;
    second += c.second;
  }
  return {first, second};
}

// Depth -> z̄ in float: z̄ = fma(d, scale, offset), and the exact float form of "d outside
// [near, far]" (d < near_f or d > far_f with near_f the least float >= near_m and far_f the
// greatest float <= far_m, so the comparisons agree with ones in double).
struct FloatNormalisation {
  float scale, offset, near_f, far_f;

  explicit FloatNormalisation(const DepthNormalisation& n)
      : scale(static_cast<float>(2.0 / (n.far_m - n.near_m))),
        offset(static_cast<float>(-1.0 - 2.0 * n.near_m / (n.far_m - n.near_m))),
        near_f(static_cast<float>(n.near_m)),
        far_f(static_cast<float>(n.far_m)) {
    constexpr float kInf = std::numeric_limits<float>::infinity();
    if (static_cast<double>(near_f) < n.near_m) near_f = std::nextafter(near_f, kInf);
    if (static_cast<double>(far_f) > n.far_m) far_f = std::nextafter(far_f, -kInf);
  }
};

// True for NaN and infinities: an all-ones exponent, tested on the bits so that the loop
// vectorizes (std::isfinite does not under GCC without -ffinite-math).
inline bool NonFinite(float value) {
  return (std::bit_cast<uint32_t>(value) & 0x7f800000u) == 0x7f800000u;
}

// keep ? x : y for a mask `keep` of all ones or all zeros, on the bits. A plain `?:` whose arm
// is a float operation (x = f * inv) is control flow to GCC under the default -ftrapping-math:
// it sinks the operation into the arm and then cannot if-convert it, and the loop stays scalar.
// Lanes that are masked out may hold inf or NaN; the mask drops them.
inline float Blend(uint32_t keep, float x, float y) {
  return std::bit_cast<float>((std::bit_cast<uint32_t>(x) & keep) |
                              (std::bit_cast<uint32_t>(y) & ~keep));
}
constexpr uint32_t kAll = ~0u;

// Pixels [begin, end) of `depth` as five planes (coverage 1 or 0, then z̄ .. z̄⁴ weighted by it;
// thesis §4.1.5's [-1, 1] normalisation, clamped). Counts invalid (first) and clamped (second)
// depths.
__attribute__((target_clones("arch=x86-64-v3", "default"))) Counts DepthToPlanes(
    const float* __restrict depth, int64_t begin, int64_t end, int64_t pixels, FloatNormalisation n,
    float* __restrict planes) {
  int64_t invalid = 0, clamped = 0;
#pragma omp simd reduction(+ : invalid, clamped)
  for (int64_t p = begin; p < end; ++p) {
    const float d = depth[p];
    const uint32_t valid = NonFinite(d) ? 0u : kAll;
    invalid += valid ? 0 : 1;
    clamped += (((d < n.near_f) | (d > n.far_f)) & (valid != 0)) ? 1 : 0;
    const float z =
        Blend(valid, std::min(std::max(std::fma(d, n.scale, n.offset), -1.0f), 1.0f), 0.0f);
    const float z2 = z * z;
    planes[p] = valid ? 1.0f : 0.0f;
    planes[pixels + p] = z;
    planes[2 * pixels + p] = z2;
    planes[3 * pixels + p] = z2 * z;
    planes[4 * pixels + p] = z2 * z2;
  }
  return {invalid, clamped};
}

// ---- float division by the coverage and quantization (thesis eq. 4.4) --------------------------

constexpr float kSqrt3F = static_cast<float>(std::numbers::sqrt3);

// clamp(unit, 0, 1) * 65535 rounded half up; EncodeOptimized64 rounds half away from zero, the
// same for non-negative values. NaN cannot occur (finite filter output, coverage > 0).
inline int32_t ToCode(float unit) {
  const float clamped = std::min(std::max(unit, 0.0f), 1.0f);
  return static_cast<int32_t>(std::fma(clamped, 65535.0f, 0.5f));
}

// b / b_0 of texel p of the filtered planes `f`, or the far plane where the texel is empty.
struct TexelMoments {
  uint32_t has;  // all ones: coverage > kMinCoverage
  float b1, b2, b3, b4;
};
inline TexelMoments Divide(const float* __restrict f, int64_t p, int64_t pixels) {
  const float c = f[p];
  const uint32_t has = c > kMinCoverage ? kAll : 0u;
  const float inv = 1.0f / c;  // inf or NaN where empty: blended away
  return {has, Blend(has, f[pixels + p] * inv, kFarPlane),
          Blend(has, f[2 * pixels + p] * inv, kFarPlane),
          Blend(has, f[3 * pixels + p] * inv, kFarPlane),
          Blend(has, f[4 * pixels + p] * inv, kFarPlane)};
}

// Texels [begin, end) of the filtered planes `f` in the 64-bit optimized form Θ of eq. 4.4.
// Counts the empty texels (first).
__attribute__((target_clones("arch=x86-64-v3", "default"))) Counts StoreOptimized64(
    const float* __restrict f, int64_t begin, int64_t end, int64_t pixels,
    uint16_t* __restrict codes) {
  int64_t empty = 0;
#pragma omp simd reduction(+ : empty)
  for (int64_t p = begin; p < end; ++p) {
    const TexelMoments t = Divide(f, p, pixels);
    empty += t.has ? 0 : 1;
    codes[4 * p] = static_cast<uint16_t>(ToCode(std::fma(1.5f, t.b1, std::fma(-2.0f, t.b3, 0.5f))));
    codes[4 * p + 1] = static_cast<uint16_t>(ToCode(4.0f * (t.b2 - t.b4)));
    codes[4 * p + 2] = static_cast<uint16_t>(
        ToCode(std::fma(0.5f * kSqrt3F, t.b1, std::fma(-2.0f * kSqrt3F / 9.0f, t.b3, 0.5f))));
    codes[4 * p + 3] = static_cast<uint16_t>(ToCode(0.5f * (t.b2 + t.b4)));
  }
  return {empty, 0};
}

// The same texels as b_1..b_4 floats.
__attribute__((target_clones("arch=x86-64-v3", "default"))) Counts StoreFloat128(
    const float* __restrict f, int64_t begin, int64_t end, int64_t pixels,
    float* __restrict moments) {
  int64_t empty = 0;
#pragma omp simd reduction(+ : empty)
  for (int64_t p = begin; p < end; ++p) {
    const TexelMoments t = Divide(f, p, pixels);
    empty += t.has ? 0 : 1;
    moments[4 * p] = t.b1;
    moments[4 * p + 1] = t.b2;
    moments[4 * p + 2] = t.b3;
    moments[4 * p + 3] = t.b4;
  }
  return {empty, 0};
}

// Checks of the per-frame inputs.
absl::Status CheckDepthSize(ImageGeometry geometry, int returns, size_t size,
                            absl::string_view what) {
  const int64_t expected = int64_t{returns} * geometry.pixel_count();
  if (static_cast<int64_t>(size) != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, " size = ", size, ". Violated constraint: returns * width * height = ", returns,
        " * ", geometry.width, " * ", geometry.height, " = ", expected));
  }
  return absl::OkStatus();
}

absl::Status CheckReturns(ImageGeometry geometry, int returns, std::span<const float> depth_m,
                          std::span<const float> weight) {
  if (returns < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("returns = ", returns, ". Violated constraint: returns >= 1"));
  }
  if (absl::Status s = CheckDepthSize(geometry, returns, depth_m.size(), "depth_m"); !s.ok()) {
    return s;
  }
  return CheckDepthSize(geometry, returns, weight.size(), "weight");
}

void PrepareOutput(ImageGeometry geometry, const MomentDepthMapOptions& options,
                   MomentDepthMap* out) {
  out->geometry = geometry;
  out->options = options;
  const size_t values = static_cast<size_t>(4 * geometry.pixel_count());
  if (options.format == MomentMapFormat::kOptimized64) {
    out->quantized.resize(values);
    out->moments.clear();
  } else {
    out->moments.resize(values);
    out->quantized.clear();
  }
  out->invalid_depths = out->clamped_depths = out->empty_texels = 0;
}

// ---- the scalar reference ------------------------------------------------------------------

// Filters five double-computed planes (stored as float, the filter's input type) with the direct
// convolution and stores texels via EncodeOptimized64. Shared by both reference builds.
absl::Status ReferenceFilterAndStore(const std::optional<GaussianMomentFilter>& filter,
                                     std::vector<float> planes, MomentDepthMap* out) {
  const int64_t pixels = out->geometry.pixel_count();
  std::vector<float> filtered;
  if (filter.has_value()) {
    filtered.resize(planes.size());
    if (absl::Status s = filter->ApplyReference(planes, filtered); !s.ok()) return s;
  } else {
    filtered = std::move(planes);
  }
  for (int64_t p = 0; p < pixels; ++p) {
    PowerMoments b;
    for (int j = 0; j < kChannels; ++j) {
      b[j] = filtered[static_cast<size_t>(j * pixels + p)];
    }
    const bool empty = !(b[0] > kMinCoverage);
    if (empty) {
      ++out->empty_texels;
      b = {1.0, kFarPlane, kFarPlane, kFarPlane, kFarPlane};
    }
    if (out->options.format == MomentMapFormat::kOptimized64) {
      QuantizedMoments64 q;
      EncodeOptimized64(b, &q);
      std::copy(q.channel.begin(), q.channel.end(), out->quantized.begin() + 4 * p);
    } else {
      for (int j = 1; j < kChannels; ++j) {
        out->moments[static_cast<size_t>(4 * p + j - 1)] = static_cast<float>(b[j] / b[0]);
      }
    }
  }
  return absl::OkStatus();
}

void StorePixelMoments(const PowerMoments& b, int64_t p, int64_t pixels,
                       std::vector<float>* planes) {
  for (int j = 0; j < kChannels; ++j) {
    (*planes)[static_cast<size_t>(j * pixels + p)] = static_cast<float>(b[j]);
  }
}

}  // namespace

// ---- MomentDepthMapOptions, MomentDepthMap -----------------------------------------------------

absl::Status MomentDepthMapOptions::Validate() const {
  if (absl::Status s = normalisation.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("MomentDepthMapOptions.normalisation: ", s.message()));
  }
  if (!(std::isfinite(sigma_px) && sigma_px >= 0.0)) {
    return absl::InvalidArgumentError(absl::StrCat("MomentDepthMapOptions.sigma_px = ", sigma_px,
                                                   ". Violated constraint: finite and >= 0"));
  }
  return absl::OkStatus();
}

PowerMomentsF MomentDepthMap::Texel(int x, int y) const {
  assert(x >= 0 && x < geometry.width && y >= 0 && y < geometry.height);
  const size_t at = static_cast<size_t>(4 * (int64_t{y} * geometry.width + x));
  if (options.format == MomentMapFormat::kOptimized64) {
    assert(at + 4 <= quantized.size());
    QuantizedMoments64 q;
    std::copy_n(quantized.begin() + static_cast<std::ptrdiff_t>(at), 4, q.channel.begin());
    return DecodeOptimized64F(q);
  }
  assert(at + 4 <= moments.size());
  return {1.0f, moments[at], moments[at + 1], moments[at + 2], moments[at + 3]};
}

float MomentDepthMap::Occlusion(int x, int y, double depth_m) const {
  // thesis §4.1.3: each format's bias (Hamburger4Occlusion treats a NaN query as "nothing").
  const float z_f = static_cast<float>(options.normalisation.Normalise(depth_m));
  const PowerMomentsF b = Texel(x, y);
  const MomentBias& bias =
      options.format == MomentMapFormat::kOptimized64 ? kQuantized16MomentBias : kFloatMomentBias;
  return Hamburger4Occlusion(b, z_f, bias);
}

// ---- MomentDepthMapBuilder ---------------------------------------------------------------------

MomentDepthMapBuilder::MomentDepthMapBuilder(ImageGeometry geometry,
                                             const MomentDepthMapOptions& options,
                                             std::optional<GaussianMomentFilter> filter)
    : geometry_(geometry), options_(options), filter_(std::move(filter)) {}

absl::StatusOr<MomentDepthMapBuilder> MomentDepthMapBuilder::Create(
    ImageGeometry geometry, const MomentDepthMapOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (geometry.width <= 0 || geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("image size = ", geometry.width, " x ",
                                                   geometry.height,
                                                   ". Violated constraint: width, height > 0"));
  }
  std::optional<GaussianMomentFilter> filter;
  if (options.sigma_px > 0.0) {
    absl::StatusOr<GaussianMomentFilter> created =
        GaussianMomentFilter::Create(options.sigma_px, geometry, kChannels);
    if (!created.ok()) return created.status();
    filter.emplace(*std::move(created));
  }
  return MomentDepthMapBuilder(geometry, options, std::move(filter));
}

absl::Status MomentDepthMapBuilder::Build(std::span<const float> depth_m, MomentDepthMap* out) {
  if (absl::Status s = CheckDepthSize(geometry_, 1, depth_m.size(), "depth_m"); !s.ok()) return s;
  PrepareOutput(geometry_, options_, out);
  const int64_t pixels = geometry_.pixel_count();
  planes_.resize(static_cast<size_t>(kChannels * pixels));
  const FloatNormalisation n(options_.normalisation);
  const float* depth = depth_m.data();
  float* planes = planes_.data();
  const Counts counts = ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
    return DepthToPlanes(depth, begin, end, pixels, n, planes);
  });
  out->invalid_depths = counts.first;
  out->clamped_depths = counts.second;
  return FilterAndStore(out);
}

absl::Status MomentDepthMapBuilder::BuildFromReturns(int returns, std::span<const float> depth_m,
                                                     std::span<const float> weight,
                                                     MomentDepthMap* out) {
  if (absl::Status s = CheckReturns(geometry_, returns, depth_m, weight); !s.ok()) return s;
  PrepareOutput(geometry_, options_, out);
  const int64_t pixels = geometry_.pixel_count();
  planes_.resize(static_cast<size_t>(kChannels * pixels));
  const DepthNormalisation& n = options_.normalisation;
  const double scale = 2.0 / (n.far_m - n.near_m);
  const double offset = -1.0 - 2.0 * n.near_m / (n.far_m - n.near_m);
  int64_t invalid = 0, clamped = 0;
  float* planes = planes_.data();
  // Per pixel sums in double (a handful of returns; weights of any finite size must not
  // overflow the sum), stored as float.
#pragma omp parallel for num_threads(KernelThreads()) schedule(static) reduction(+ : invalid, clamped) \
    if (pixels > kBlockPixels)
  for (int64_t p = 0; p < pixels; ++p) {
    double sum[kChannels] = {};
    for (int r = 0; r < returns; ++r) {
      const size_t at = static_cast<size_t>(r * pixels + p);
      const double d = depth_m[at], w = weight[at];
      if (!(std::isfinite(d) && std::isfinite(w) && w > 0.0)) {
        ++invalid;
        continue;
      }
      if (d < n.near_m || d > n.far_m) ++clamped;
      const double z = std::clamp(std::fma(d, scale, offset), -1.0, 1.0);
      const double z2 = z * z;
      sum[0] += w;
      sum[1] += w * z;
      sum[2] += w * z2;
      sum[3] += w * z2 * z;
      sum[4] += w * z2 * z2;
    }
    const double inv = sum[0] > 0.0 ? 1.0 / sum[0] : 0.0;
    planes[p] = sum[0] > 0.0 ? 1.0f : 0.0f;
    for (int j = 1; j < kChannels; ++j) planes[j * pixels + p] = static_cast<float>(sum[j] * inv);
  }
  out->invalid_depths = invalid;
  out->clamped_depths = clamped;
  return FilterAndStore(out);
}

absl::Status MomentDepthMapBuilder::FilterAndStore(MomentDepthMap* out) {
  const int64_t pixels = geometry_.pixel_count();
  const float* f = planes_.data();
  if (filter_.has_value()) {
    filtered_.resize(planes_.size());
    if (absl::Status s = filter_->Apply(planes_, filtered_); !s.ok()) return s;
    f = filtered_.data();
  }
  if (options_.format == MomentMapFormat::kOptimized64) {
    uint16_t* codes = out->quantized.data();
    out->empty_texels = ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
                          return StoreOptimized64(f, begin, end, pixels, codes);
                        }).first;
  } else {
    float* moments = out->moments.data();
    out->empty_texels = ParallelBlocks(pixels, [&](int64_t begin, int64_t end) {
                          return StoreFloat128(f, begin, end, pixels, moments);
                        }).first;
  }
  return absl::OkStatus();
}

absl::Status MomentDepthMapBuilder::BuildReference(std::span<const float> depth_m,
                                                   MomentDepthMap* out) const {
  if (absl::Status s = CheckDepthSize(geometry_, 1, depth_m.size(), "depth_m"); !s.ok()) return s;
  PrepareOutput(geometry_, options_, out);
  const int64_t pixels = geometry_.pixel_count();
  std::vector<float> planes(static_cast<size_t>(kChannels * pixels));
  for (int64_t p = 0; p < pixels; ++p) {
    PowerMoments b;
    const DepthSample sample =
        DepthMoments(depth_m[static_cast<size_t>(p)], options_.normalisation, &b);
    if (sample == DepthSample::kInvalid) ++out->invalid_depths;
    if (sample == DepthSample::kClamped) ++out->clamped_depths;
    StorePixelMoments(b, p, pixels, &planes);
  }
  return ReferenceFilterAndStore(filter_, std::move(planes), out);
}

absl::Status MomentDepthMapBuilder::BuildFromReturnsReference(int returns,
                                                              std::span<const float> depth_m,
                                                              std::span<const float> weight,
                                                              MomentDepthMap* out) const {
  if (absl::Status s = CheckReturns(geometry_, returns, depth_m, weight); !s.ok()) return s;
  PrepareOutput(geometry_, options_, out);
  const int64_t pixels = geometry_.pixel_count();
  std::vector<float> planes(static_cast<size_t>(kChannels * pixels));
  std::vector<double> depths(static_cast<size_t>(returns)), weights(depths.size());
  for (int64_t p = 0; p < pixels; ++p) {
    for (int r = 0; r < returns; ++r) {
      const size_t at = static_cast<size_t>(r * pixels + p);
      depths[static_cast<size_t>(r)] = depth_m[at];
      weights[static_cast<size_t>(r)] = weight[at];
      PowerMoments one;
      const double w = weight[at];
      if (!(std::isfinite(w) && w > 0.0) ||
          DepthMoments(depth_m[at], options_.normalisation, &one) == DepthSample::kInvalid) {
        ++out->invalid_depths;
      } else if (one[1] != options_.normalisation.Normalise(depth_m[at])) {
        ++out->clamped_depths;
      }
    }
    PowerMoments b;
    WeightedDepthMoments(depths, weights, options_.normalisation, &b);
    StorePixelMoments(b, p, pixels, &planes);
  }
  return ReferenceFilterAndStore(filter_, std::move(planes), out);
}

}  // namespace transient

// The moment depth map of one frame (moment shadow mapping on camera depth, thesis ch. 4): a
// depth image, or each pixel's weighted returns, becomes power moments of normalised depth per
// pixel, is filtered with a Gaussian and stored as 64 bits (optimized quantization, eq. 4.4) or
// 128 bits (four floats) per texel. A renderer then asks of each texel "which fraction of this
// pixel's footprint lies in front of my fragment?" (power_moments.h, OcclusionFraction).
//
// Invalid depths (NaN or infinite; 16UC1's 0 must be mapped to NaN first) carry no weight: each
// texel is normalised by the coverage of its footprint, b / b_0, so the footprint is the valid
// pixels under the filter. A texel whose whole footprint is invalid encodes one surface at the
// far plane (z̄ = 1), which occludes nothing nearer than `far`, and is counted in empty_texels.
// Finite depths outside [near, far] are clamped to the nearer end (a surface in front of `near`
// still occludes everything) and counted in clamped_depths.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moment_filter.h"
#include "transient/reconstruct/moment_quantization.h"
#include "transient/reconstruct/power_moments.h"

namespace transient {

enum class MomentMapFormat {
  // 4 x uint16 per texel: Θ(b / b_0) of thesis eq. 4.4 (EncodeOptimized64). Query with
  // OcclusionFractionOptimized64 (float decode, kQuantized16MomentBias). Wire: 16UC4.
  kOptimized64,
  // 4 x float per texel: b_1..b_4 of b / b_0 (b_0 = 1 implied). Query with
  // OcclusionFraction({1, b_1, b_2, b_3, b_4}, z̄_f) (kFloatMomentBias). Wire: 32FC4.
  kFloat128,
};

struct MomentDepthMapOptions {
  DepthNormalisation normalisation = {};  // the depth range mapped to [-1, 1], metres
  double sigma_px = 1.0;  // Gaussian standard deviation in pixels; 0 = no filter
  MomentMapFormat format = MomentMapFormat::kOptimized64;

  // InvalidArgument naming the field: the normalisation invalid (DepthNormalisation::Validate),
  // sigma_px not finite or negative.
  absl::Status Validate() const;
};

struct MomentDepthMap {
  ImageGeometry geometry = {};
  MomentDepthMapOptions options = {};
  // kOptimized64: 4 codes per texel, interleaved, row-major (channel c of texel p at 4 p + c).
  std::vector<uint16_t> quantized;
  // kFloat128: b_1..b_4 per texel, interleaved the same way.
  std::vector<float> moments;
  int64_t invalid_depths = 0;  // input depths (or returns) left out: not finite
  int64_t clamped_depths = 0;  // finite input depths outside [near, far], clamped
  int64_t empty_texels = 0;    // texels with no valid depth in their footprint: far plane

  // The texel at (x, y) as moments (1, b_1, .., b_4) in float (DecodeOptimized64F for 64 bits).
  // Requires (x, y) inside the geometry.
  PowerMomentsF Texel(int x, int y) const;
  // What a renderer computes for a virtual fragment at optical depth `depth_m` (metres) seen
  // through pixel (x, y): OcclusionFraction of the texel at the fragment's normalised depth, with
  // the format's bias. 0 = visible, 1 = hidden by the real scene; never NaN (a NaN depth gives
  // 0). Requires (x, y) inside the geometry.
  float Occlusion(int x, int y, double depth_m) const;
};

// Builds moment depth maps of one geometry and options, frame after frame, reusing its buffers
// (so a builder serves one thread at a time).
class MomentDepthMapBuilder {
 public:
  // InvalidArgument for invalid options, an empty geometry, or a filter wider than the image
  // (GaussianMomentFilter::Create's message, naming sigma and the image size).
  static absl::StatusOr<MomentDepthMapBuilder> Create(ImageGeometry geometry,
                                                      const MomentDepthMapOptions& options);

  // From a depth image (metres of optical Z, row-major, NaN = invalid). InvalidArgument naming
  // the sizes when depth_m does not hold one value per pixel. The fast path: float arithmetic,
  // OpenMP threads (GetKernelOptions().threads, kernels.h).
  absl::Status Build(std::span<const float> depth_m, MomentDepthMap* out);

  // From `returns` weighted depths per pixel (planar: return r of pixel p at r * pixels + p), e.g.
  // a pixel's Pisarenko returns converted to depth: moments of the weighted set normalised to
  // weights summing to 1 (WeightedDepthMoments). An entry is left out (invalid_depths) when its
  // depth is not finite or its weight is not finite and positive; a pixel without entries has
  // coverage 0. InvalidArgument for returns < 1 or sizes other than returns * pixels.
  absl::Status BuildFromReturns(int returns, std::span<const float> depth_m,
                                std::span<const float> weight, MomentDepthMap* out);

  // The scalar references of the two: DepthMoments / WeightedDepthMoments in double, the direct
  // convolution (GaussianMomentFilter::ApplyReference), EncodeOptimized64. Slow; for tests.
  absl::Status BuildReference(std::span<const float> depth_m, MomentDepthMap* out) const;
  absl::Status BuildFromReturnsReference(int returns, std::span<const float> depth_m,
                                         std::span<const float> weight,
                                         MomentDepthMap* out) const;

  ImageGeometry geometry() const { return geometry_; }
  const MomentDepthMapOptions& options() const { return options_; }

 private:
  MomentDepthMapBuilder(ImageGeometry geometry, const MomentDepthMapOptions& options,
                        std::optional<GaussianMomentFilter> filter);

  // Filters planes_ into filtered_ (or uses planes_ as is for sigma 0), then divides by the
  // filtered coverage and writes `out` in the chosen format.
  absl::Status FilterAndStore(MomentDepthMap* out);

  ImageGeometry geometry_;
  MomentDepthMapOptions options_;
  std::optional<GaussianMomentFilter> filter_;  // absent for sigma_px == 0
  // Five planar float channels (coverage, then coverage-weighted z̄ .. z̄⁴), before and after
  // the filter; reused frame after frame.
  std::vector<float> planes_;
  std::vector<float> filtered_;
};

}  // namespace transient
